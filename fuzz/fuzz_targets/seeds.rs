//! The seed-file parser: any bytes give seeds or an error, never a panic; seeds it accepts
//! survive a round trip through the seed-file writer (`to_toml`, as segment files use it).
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("fuzz.toml");
    if let Ok(seeds) = mocap2d::seed::parse_seeds(text, path) {
        let again = mocap2d::seed::to_toml(seeds.frame, &seeds.joints, "");
        let back = mocap2d::seed::parse_seeds(&again, path)
            .unwrap_or_else(|e| panic!("written seeds do not read back: {e}\n{again}"));
        assert_eq!(back.joints.len(), seeds.joints.len());
    }
});
