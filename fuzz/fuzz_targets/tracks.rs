//! The `tracks.csv` reader: any bytes give rows or an error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = mocap2d::run::tracks::parse_tracks(data, std::path::Path::new("tracks.csv"));
});
