//! `review/confidence.png`: every joint's score over time, one strip a joint, with the spans the
//! tracker flagged shaded by status and the segment boundaries marked. Drawn with imageproc
//! and the built-in bitmap font, so it needs no font or plotting library on the machine.

use super::data::RunData;
use super::draw::{self, status_colour};
use image::{Rgb, RgbImage};
use imageproc::drawing::{draw_filled_rect_mut, draw_line_segment_mut};
use imageproc::rect::Rect;

/// Plot area width in px (columns); a column covers several frames on long runs.
pub const PLOT_W: u32 = 1200;
const LEFT: u32 = 150;
const RIGHT: u32 = 16;
const TOP: u32 = 44;
const BOTTOM: u32 = 40;
const ROW_H: u32 = 36;
const ROW_GAP: u32 = 8;
const BG: Rgb<u8> = Rgb([255, 255, 255]);
const AXIS: Rgb<u8> = Rgb([60, 60, 60]);
const LINE: Rgb<u8> = Rgb([20, 40, 160]);
const SEGMENT: Rgb<u8> = Rgb([0, 120, 255]);

/// A pale version of a status colour, for shading.
fn pale(c: Rgb<u8>) -> Rgb<u8> {
    Rgb(c.0.map(|v| (v as u16 + 2 * 255).div_ceil(3) as u8))
}

/// Severity of a status word, for choosing a column's shade: lost > occluded > low > others.
fn severity(s: &str) -> u8 {
    match s {
        "lost" => 3,
        "occluded" => 2,
        "low" => 1,
        _ => 0,
    }
}

/// Draws the confidence plot of a run (see the module doc). Its size depends only on the
/// number of joints: `LEFT + PLOT_W + RIGHT` wide.
pub fn confidence(data: &RunData) -> RgbImage {
    let names: Vec<&str> = data.seeds.joints.iter().map(|j| j.name.as_str()).collect();
    let n = names.len() as u32;
    let (w, h) = (LEFT + PLOT_W + RIGHT, TOP + n * (ROW_H + ROW_GAP) + BOTTOM);
    let mut img = RgbImage::from_pixel(w, h, BG);
    let (f0, f1) = (data.first, data.end().max(data.first + 1));
    let span = (f1 - f0) as f64;
    // Frames [a, b) of column c.
    let cols: Vec<(u64, u64)> = (0..PLOT_W)
        .map(|c| {
            let a = f0 + (c as f64 * span / PLOT_W as f64).floor() as u64;
            let b = f0 + ((c + 1) as f64 * span / PLOT_W as f64).floor() as u64;
            (a, b.max(a + 1).min(f1.max(a + 1)))
        })
        .collect();
    let x_of = |f: u64| LEFT as f32 + ((f - f0) as f64 / span * PLOT_W as f64) as f32;
    let title = if data.segments.is_empty() {
        format!("score per joint, frames {f0}..{}  (no segments)", f1 - 1)
    } else {
        format!(
            "score per joint, frames {f0}..{}  ({} segments, blue lines)",
            f1 - 1,
            data.segments.len()
        )
    };
    draw::text(&mut img, 8, 6, &title, draw::BLACK, 2);
    draw::text(&mut img, 8, 26, "shaded:", AXIS, 1);
    let mut kx = 72i32;
    for s in ["low", "occluded", "lost"] {
        let tw = draw::text_width(s, 1);
        draw_filled_rect_mut(
            &mut img,
            Rect::at(kx, 24).of_size(tw + 6, 12),
            pale(status_colour(s)),
        );
        draw::text(&mut img, kx + 3, 26, s, draw::BLACK, 1);
        kx += tw as i32 + 14;
    }

    for (i, name) in names.iter().enumerate() {
        let top = TOP + i as u32 * (ROW_H + ROW_GAP);
        let y_of = |s: f32| top as f32 + (1.0 - s.clamp(0.0, 1.0)) * (ROW_H - 1) as f32;
        // Shading and score range per column.
        let mut prev: Option<(f32, f32)> = None;
        let mut ok = 0u64;
        let mut total = 0u64;
        for (c, &(a, b)) in cols.iter().enumerate() {
            let mut worst = 0u8;
            let mut worst_s = "";
            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
            for f in a..b {
                let Some(r) = data
                    .rows(f)
                    .and_then(|rows| rows.iter().find(|r| r.joint == *name))
                else {
                    continue;
                };
                total += 1;
                if severity(&r.status) == 0 {
                    ok += 1;
                }
                if severity(&r.status) > worst {
                    worst = severity(&r.status);
                    worst_s = status_str(&r.status);
                }
                lo = lo.min(r.score);
                hi = hi.max(r.score);
            }
            let x = (LEFT + c as u32) as i32;
            if worst > 0 {
                draw_filled_rect_mut(
                    &mut img,
                    Rect::at(x, top as i32).of_size(1, ROW_H),
                    pale(status_colour(worst_s)),
                );
            }
            if lo.is_finite() {
                let (top, bot) = (y_of(hi), y_of(lo));
                draw_line_segment_mut(&mut img, (x as f32, top), (x as f32, bot), LINE);
                // Join to the previous column's range where the two do not overlap.
                if let Some((ptop, pbot)) = prev {
                    let join = if top > pbot {
                        Some((pbot, top))
                    } else if bot < ptop {
                        Some((ptop, bot))
                    } else {
                        None
                    };
                    if let Some((from, to)) = join {
                        draw_line_segment_mut(
                            &mut img,
                            (x as f32 - 1.0, from),
                            (x as f32, to),
                            LINE,
                        );
                    }
                }
                prev = Some((top, bot));
            } else {
                prev = None;
            }
        }
        // Frame of the strip: 0 and 1 lines.
        let (l, r) = (LEFT as f32, (LEFT + PLOT_W) as f32);
        draw_line_segment_mut(
            &mut img,
            (l, top as f32),
            (r, top as f32),
            Rgb([200, 200, 200]),
        );
        let bottom = (top + ROW_H - 1) as f32;
        draw_line_segment_mut(&mut img, (l - 4.0, bottom), (r, bottom), AXIS);
        draw_line_segment_mut(&mut img, (l - 1.0, top as f32), (l - 1.0, bottom), AXIS);
        let shown: String = name.chars().take(17).collect();
        draw::text(&mut img, 4, top as i32 + 4, &shown, draw::BLACK, 1);
        let pct = if total > 0 {
            100.0 * ok as f64 / total as f64
        } else {
            0.0
        };
        draw::text(
            &mut img,
            4,
            top as i32 + 18,
            &format!("{pct:.0}% seen well"),
            AXIS,
            1,
        );
        draw::text(&mut img, LEFT as i32 - 12, top as i32, "1", AXIS, 1);
        draw::text(&mut img, LEFT as i32 - 12, bottom as i32 - 7, "0", AXIS, 1);
    }

    // Segment boundaries.
    let plot_bottom = TOP + n * (ROW_H + ROW_GAP);
    for s in &data.segments {
        let f = s.seeds.frame;
        if f < f0 || f >= f1 {
            continue;
        }
        let x = x_of(f);
        draw_line_segment_mut(
            &mut img,
            (x, TOP as f32 - 4.0),
            (x, plot_bottom as f32),
            SEGMENT,
        );
        draw::text(&mut img, x as i32 + 2, TOP as i32 - 10, &s.id, SEGMENT, 1);
    }
    // Frame axis with about ten ticks at round numbers.
    let step = nice_step(span / 10.0);
    let mut t = f0.div_ceil(step) * step;
    while t < f1 {
        let x = x_of(t);
        draw_line_segment_mut(
            &mut img,
            (x, plot_bottom as f32 - 2.0),
            (x, plot_bottom as f32 + 4.0),
            AXIS,
        );
        let s = t.to_string();
        draw::text(
            &mut img,
            x as i32 - draw::text_width(&s, 1) as i32 / 2,
            plot_bottom as i32 + 8,
            &s,
            AXIS,
            1,
        );
        t += step;
    }
    label_axis(&mut img, plot_bottom);
    img
}

fn status_str(s: &str) -> &'static str {
    match s {
        "lost" => "lost",
        "occluded" => "occluded",
        _ => "low",
    }
}

fn label_axis(img: &mut RgbImage, plot_bottom: u32) {
    let s = "frame";
    let x = (LEFT + PLOT_W / 2) as i32 - draw::text_width(s, 1) as i32 / 2;
    draw::text(img, x, plot_bottom as i32 + 22, s, AXIS, 1);
}

/// The smallest of 1, 2, 5, 10, 20, 50, … frames at least `raw`.
pub fn nice_step(raw: f64) -> u64 {
    let mut m = 1u64;
    loop {
        for k in [1, 2, 5] {
            if (k * m) as f64 >= raw {
                return k * m;
            }
        }
        m *= 10;
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn steps_are_round() {
        assert_eq!(super::nice_step(0.3), 1);
        assert_eq!(super::nice_step(3.0), 5);
        assert_eq!(super::nice_step(14.0), 20);
        assert_eq!(super::nice_step(1500.0), 2000);
    }
}
