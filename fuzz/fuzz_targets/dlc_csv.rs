//! The DeepLabCut CSV reader: any text gives a table or an error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = mocap2d::seed::dlc_csv::parse_dlc_csv(text, std::path::Path::new("labels.csv"));
});
