//! The segment-file reader (`resume` and `track` read `segments/NNN.toml` with it): any bytes
//! give a segment start or an error, never a panic. The run is the sample's (`clips/walk`,
//! 320×240) and the file is segment 1's, on frame 20.
#![no_main]
use libfuzzer_sys::fuzz_target;
use mocap2d::run::segments::Start;
use mocap2d::seed::Seeds;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn base() -> &'static Seeds {
    static BASE: OnceLock<Seeds> = OnceLock::new();
    BASE.get_or_init(|| {
        let text = include_str!("../../clips/walk/joints.toml");
        mocap2d::seed::parse_seeds(text, Path::new("seeds.toml")).expect("the sample's seeds")
    })
}

fn file() -> &'static PathBuf {
    static FILE: OnceLock<PathBuf> = OnceLock::new();
    FILE.get_or_init(|| tempfile::tempdir().expect("temp dir").keep().join("001.toml"))
}

fuzz_target!(|data: &[u8]| {
    std::fs::write(file(), data).expect("write the segment file");
    for rotate_roots in [false, true] {
        if let Ok(start) = Start::read(file(), 20, base(), 320, 240, rotate_roots, &[]) {
            assert_eq!(start.row.len(), base().joints.len());
            assert_eq!(start.angles.len(), base().joints.len());
            assert!(start.corrected, "no hash was recorded, so it is a correction");
        }
    }
});
