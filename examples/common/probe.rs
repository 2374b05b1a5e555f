//! Shared by the diagnostics examples: a picture of one bone's samples.

use image::{Rgb, RgbImage};
use imageproc::drawing::draw_filled_rect_mut;
use imageproc::rect::Rect;
use mocap2d::geom::Point;

/// Saves to `path` an 80×80 px window of `frame` around the middle of the bone `p`–`c`, six
/// times enlarged, with each of `samples` (x, y, residual, weight from `Tracker::probe_bone`)
/// marked: green fits (residual < 2.5), red does not, grey carries no weight.
pub fn save_probe(
    frame: &RgbImage,
    p: Point,
    c: Point,
    samples: &[(f32, f32, f32, f32)],
    path: &str,
) {
    let (cx, cy) = ((p.x + c.x) / 2.0, (p.y + c.y) / 2.0);
    let (x0, y0, sc, side) = (cx - 40.0, cy - 40.0, 6.0f32, 480u32);
    let mut img = RgbImage::new(side, side);
    for (x, y, px) in img.enumerate_pixels_mut() {
        let (fx, fy) = ((x0 + x as f32 / sc) as u32, (y0 + y as f32 / sc) as u32);
        if fx < frame.width() && fy < frame.height() {
            *px = *frame.get_pixel(fx, fy);
        }
    }
    for &(x, y, e, w) in samples {
        let (ix, iy) = (((x - x0 + 0.5) * sc) as i32, ((y - y0 + 0.5) * sc) as i32);
        let col = if w <= 0.0 {
            Rgb([128, 128, 128])
        } else if e < 2.5 {
            Rgb([0, 255, 0])
        } else {
            Rgb([255, 0, 0])
        };
        draw_filled_rect_mut(&mut img, Rect::at(ix - 1, iy - 1).of_size(3, 3), col);
    }
    img.save(path).unwrap();
}
