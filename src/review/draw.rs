//! Drawing helpers shared by the guide, the overlay and the plots: rotated joint rectangles,
//! thick lines, status colours, and text in the public-domain 8×8 bitmap font of `font8x8` (no
//! font files, no system fonts, the same pixels on every machine).

use crate::geom::JointBox;
use image::{Rgb, RgbImage};
use imageproc::drawing::{draw_filled_circle_mut, draw_filled_rect_mut, draw_line_segment_mut};
use imageproc::rect::Rect;

/// Glyph cell size of the bitmap font at scale 1, px.
pub const GLYPH: u32 = 8;

pub const WHITE: Rgb<u8> = Rgb([255, 255, 255]);
pub const BLACK: Rgb<u8> = Rgb([0, 0, 0]);
pub const GREY: Rgb<u8> = Rgb([150, 150, 150]);

/// The colour a joint is drawn in for a `tracks.csv` status word: seed cyan, ok green, low
/// yellow, occluded orange, lost red; anything else (a segment file without status) white.
pub fn status_colour(status: &str) -> Rgb<u8> {
    match status {
        "seed" => Rgb([0, 220, 255]),
        "ok" => Rgb([40, 220, 60]),
        "low" => Rgb([255, 220, 0]),
        "occluded" => Rgb([255, 140, 0]),
        "lost" => Rgb([240, 30, 30]),
        _ => WHITE,
    }
}

/// The four corners of a joint box rotated by its angle about its centre (px, clockwise on
/// screen; see [`crate::geom`]), in order around the box.
pub fn box_corners(b: &JointBox) -> [(f32, f32); 4] {
    let (s, c) = b.angle_rad.sin_cos();
    let (hw, hh) = (b.w as f32 / 2.0, b.h as f32 / 2.0);
    [(-hw, -hh), (hw, -hh), (hw, hh), (-hw, hh)]
        .map(|(dx, dy)| (b.cx + c * dx - s * dy, b.cy + s * dx + c * dy))
}

/// A line `thickness` px wide (drawn as parallel one-pixel lines).
pub fn thick_line(
    img: &mut RgbImage,
    a: (f32, f32),
    b: (f32, f32),
    colour: Rgb<u8>,
    thickness: u32,
) {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len = (dx * dx + dy * dy).sqrt().max(1e-6);
    let (nx, ny) = (-dy / len, dx / len);
    let t = thickness.max(1) as f32;
    let mut o = -(t - 1.0) / 2.0;
    while o <= (t - 1.0) / 2.0 + 1e-3 {
        let shift = |p: (f32, f32)| (p.0 + nx * o, p.1 + ny * o);
        draw_line_segment_mut(img, shift(a), shift(b), colour);
        o += 1.0;
    }
}

/// A joint box's outline, rotated, `thickness` px wide, with a tick from the centre to the
/// middle of its right edge so the rotation shows.
pub fn joint_box(img: &mut RgbImage, b: &JointBox, colour: Rgb<u8>, thickness: u32) {
    let c = box_corners(b);
    for i in 0..4 {
        thick_line(img, c[i], c[(i + 1) % 4], colour, thickness);
    }
    let mid = ((c[1].0 + c[2].0) / 2.0, (c[1].1 + c[2].1) / 2.0);
    draw_line_segment_mut(img, (b.cx, b.cy), mid, colour);
}

/// A filled dot of `radius` px with a black rim.
pub fn dot(img: &mut RgbImage, at: (f32, f32), radius: i32, colour: Rgb<u8>) {
    let c = (at.0.round() as i32, at.1.round() as i32);
    draw_filled_circle_mut(img, c, radius + 1, BLACK);
    draw_filled_circle_mut(img, c, radius, colour);
}

/// Width in px of `text` at `scale`.
pub fn text_width(text: &str, scale: u32) -> u32 {
    text.chars().count() as u32 * GLYPH * scale
}

/// Draws `text` (ASCII; other characters as `?`) with its top-left corner at `(x, y)`, each font
/// pixel a `scale × scale` square. Parts outside the image are clipped.
pub fn text(img: &mut RgbImage, x: i32, y: i32, text: &str, colour: Rgb<u8>, scale: u32) {
    let s = scale.max(1) as i32;
    for (k, ch) in text.chars().enumerate() {
        let code = if ch.is_ascii() {
            ch as usize
        } else {
            '?' as usize
        };
        let glyph = font8x8::legacy::BASIC_LEGACY[code];
        let gx = x + k as i32 * GLYPH as i32 * s;
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                if bits & (1 << col) == 0 {
                    continue;
                }
                let (px, py) = (gx + col * s, y + row as i32 * s);
                for yy in py..py + s {
                    for xx in px..px + s {
                        if xx >= 0
                            && yy >= 0
                            && (xx as u32) < img.width()
                            && (yy as u32) < img.height()
                        {
                            img.put_pixel(xx as u32, yy as u32, colour);
                        }
                    }
                }
            }
        }
    }
}

/// Text on a filled black box (a label legible on any background), top-left at `(x, y)`,
/// moved inside the image when it would stick out.
pub fn label(img: &mut RgbImage, x: i32, y: i32, s: &str, colour: Rgb<u8>, scale: u32) {
    let (w, h) = (text_width(s, scale) + 2, GLYPH * scale.max(1) + 2);
    let x = x.min(img.width() as i32 - w as i32).max(0);
    let y = y.min(img.height() as i32 - h as i32).max(0);
    draw_filled_rect_mut(img, Rect::at(x, y).of_size(w, h), BLACK);
    text(img, x + 1, y + 1, s, colour, scale);
}

/// Blends `colour` over the pixel at `(x, y)` with weight `alpha` (0–1).
pub fn tint(img: &mut RgbImage, x: u32, y: u32, colour: Rgb<u8>, alpha: f32) {
    let p = img.get_pixel_mut(x, y);
    for c in 0..3 {
        p.0[c] = (p.0[c] as f32 * (1.0 - alpha) + colour.0[c] as f32 * alpha).round() as u8;
    }
}

/// Encodes an image as PNG bytes.
pub fn png_bytes(img: &RgbImage) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png)
        .expect("PNG encoding into memory cannot fail");
    out.into_inner()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_rotate_clockwise_on_screen() {
        let mut b = JointBox::centred(10.0, 10.0, 4, 2);
        b.angle_rad = std::f32::consts::FRAC_PI_2;
        // The right edge's middle (12, 10) turns a quarter clockwise on screen: to (10, 12).
        let c = box_corners(&b);
        let mid = ((c[1].0 + c[2].0) / 2.0, (c[1].1 + c[2].1) / 2.0);
        assert!(
            (mid.0 - 10.0).abs() < 1e-4 && (mid.1 - 12.0).abs() < 1e-4,
            "{mid:?}"
        );
    }

    #[test]
    fn text_draws_glyph_pixels_and_clips() {
        let mut img = RgbImage::new(20, 10);
        text(&mut img, 0, 0, "H", WHITE, 1);
        let lit = img.pixels().filter(|p| p.0 == [255, 255, 255]).count();
        assert!(lit > 10, "{lit}");
        // Off the image: nothing drawn, no panic.
        let mut img = RgbImage::new(4, 4);
        text(&mut img, -100, 50, "abc", WHITE, 2);
        assert!(img.pixels().all(|p| p.0 == [0, 0, 0]));
    }
}
