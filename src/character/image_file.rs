//! The character's image: loaded and checked (alpha, size), and where it is opaque.

use super::ALPHA_INSIDE;
use crate::error::{Error, Result};
use image::RgbaImage;
use std::path::Path;

/// Loads a PNG with an alpha channel; errors go through `err` (user errors).
pub(super) fn load_image(path: &Path, err: &dyn Fn(String) -> Error) -> Result<RgbaImage> {
    if !path.is_file() {
        return Err(err(format!(
            "image {} not found; `image` is relative to the character file",
            path.display()
        )));
    }
    let cannot =
        |e: image::ImageError| err(format!("image {}: cannot decode: {e}", path.display()));
    // The size from the header first: a huge image is refused before it is decoded.
    let (w, h) = image::image_dimensions(path).map_err(cannot)?;
    if w < 8 || h < 8 || w > 8192 || h > 8192 {
        return Err(err(format!(
            "image {} is {w}×{h} px; use 8 to 8192 px a side",
            path.display()
        )));
    }
    let img = image::open(path).map_err(cannot)?;
    if !img.color().has_alpha() {
        return Err(err(format!(
            "image {} has no alpha channel; save it as a PNG with transparency around the character",
            path.display()
        )));
    }
    let img = img.to_rgba8();
    if img.width() < 8 || img.height() < 8 || img.width() > 8192 || img.height() > 8192 {
        return Err(err(format!(
            "image {} is {}×{} px; use 8 to 8192 px a side",
            path.display(),
            img.width(),
            img.height()
        )));
    }
    Ok(img)
}

/// True when a pixel within `radius` px of `(x, y)` has alpha >= [`ALPHA_INSIDE`].
pub(super) fn near_opaque(img: &RgbaImage, x: f32, y: f32, radius: i32) -> bool {
    let (cx, cy) = (x.round() as i32, y.round() as i32);
    (-radius..=radius).any(|dy| {
        (-radius..=radius).any(|dx| {
            let (px, py) = (cx + dx, cy + dy);
            px >= 0
                && py >= 0
                && (px as u32) < img.width()
                && (py as u32) < img.height()
                && img.get_pixel(px as u32, py as u32)[3] >= ALPHA_INSIDE
        })
    })
}
