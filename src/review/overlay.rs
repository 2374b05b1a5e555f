//! The overlay: a frame with what the tracker concluded about it drawn on top — every joint's
//! rotated rectangle coloured by status, the skeleton's bones, the joints' names, and a line
//! telling the frame, its segment and the colour key.

use super::data::RunData;
use super::draw::{self, status_colour};
use crate::geom::JointBox;
use image::{Rgb, RgbImage};

/// The statuses in the colour key, in order.
pub const STATUSES: [&str; 5] = ["seed", "ok", "low", "occluded", "lost"];

/// Text scale for a frame `height` px high: 1 up to 539 px, then 2, 3, ….
pub fn text_scale(height: u32) -> u32 {
    (height / 540 + 1).max(1)
}

/// The joint rectangles of frame `f`: position and angle from `tracks.csv`, size from the
/// segment file the frame falls in (else `seeds.toml`), with each row's status. Empty before
/// the first tracked frame.
pub fn boxes_at(data: &RunData, f: u64) -> Vec<(String, JointBox, String)> {
    let Some(rows) = data.rows(f) else {
        return Vec::new();
    };
    let sizes = data
        .segment_of(f)
        .map_or(&data.seeds.joints, |k| &data.segments[k].seeds.joints);
    rows.iter()
        .map(|r| {
            let (w, h) = sizes
                .iter()
                .chain(&data.seeds.joints)
                .find(|j| j.name == r.joint)
                .map_or((15, 15), |j| (j.bbox.w, j.bbox.h));
            let mut b = JointBox::centred(r.x, r.y, w, h);
            b.angle_rad = r.angle;
            (r.joint.clone(), b, r.status.clone())
        })
        .collect()
}

/// Draws bones (parent centre to child centre) and then the `boxes` with their names. Lines are
/// `thickness` px wide and text `scale` times the 8-px font.
pub fn draw_boxes(
    img: &mut RgbImage,
    data: &RunData,
    boxes: &[(String, JointBox, String)],
    thickness: u32,
    scale: u32,
    names: bool,
) {
    let at = |name: &str| boxes.iter().find(|b| b.0 == name).map(|b| (b.1.cx, b.1.cy));
    for j in &data.seeds.joints {
        if let (Some(p), Some(c)) = (j.parent.as_deref().and_then(at), at(&j.name)) {
            draw::thick_line(img, p, c, draw::BLACK, thickness + 2);
            draw::thick_line(img, p, c, Rgb([230, 230, 230]), thickness);
        }
    }
    for (_, b, status) in boxes {
        draw::joint_box(img, b, status_colour(status), thickness);
    }
    if names {
        for (name, b, status) in boxes {
            let x = b.cx + b.w.max(b.h) as f32 * 0.5 + 2.0;
            let y = b.cy - b.h as f32 * 0.5 - (draw::GLYPH * scale) as f32;
            draw::label(img, x as i32, y as i32, name, status_colour(status), scale);
        }
    }
}

/// Draws frame `f`'s overlay onto `img` (the decoded frame).
pub fn draw_frame(img: &mut RgbImage, data: &RunData, f: u64) {
    let scale = text_scale(img.height());
    let boxes = boxes_at(data, f);
    draw_boxes(img, data, &boxes, scale, scale, true);
    let seg = data
        .segment_of(f)
        .map(|k| format!(" segment {}", data.segments[k].id))
        .unwrap_or_default();
    let head = if boxes.is_empty() {
        format!("frame {f} (not tracked)")
    } else {
        format!("frame {f}{seg}")
    };
    draw::label(img, 2, 2, &head, draw::WHITE, scale);
    // Colour key, bottom left.
    let mut x = 2i32;
    let y = img.height() as i32 - (draw::GLYPH * scale) as i32 - 4;
    for s in STATUSES {
        draw::label(img, x, y, s, status_colour(s), scale);
        x += (draw::text_width(s, scale) + 6 * scale) as i32;
    }
}
