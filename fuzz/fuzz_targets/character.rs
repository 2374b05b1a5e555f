//! The character-file parser: any text gives a character or an error, never a panic. The file
//! "lives" in a temp folder holding a small opaque image `c.png` for `image = "c.png"`.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::PathBuf;
use std::sync::OnceLock;

fn dir() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::tempdir().expect("temp dir").keep();
        let img = image::RgbaImage::from_pixel(16, 16, image::Rgba([90, 60, 30, 255]));
        img.save(dir.join("c.png")).expect("write c.png");
        dir
    })
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = mocap2d::character::parse_character(text, &dir().join("char.toml"));
});
