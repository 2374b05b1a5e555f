//! The run manifest (`run.toml`): any text gives a manifest or an error, never a panic; a
//! manifest it accepts is written back as TOML that reads back.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("run.toml");
    if let Ok(m) = mocap2d::run::Manifest::parse(text, path) {
        let again = m.to_toml();
        mocap2d::run::Manifest::parse(&again, path)
            .unwrap_or_else(|e| panic!("written manifest does not read back: {e}\n{again}"));
    }
});
