//! `review/segments.png`: a contact sheet of every segment's first frame with the rectangles of
//! its segment file, so a bad start is seen at a glance. A run without `segments/` gets every
//! [`EVERY_NTH`]th tracked frame with its tracked rectangles instead, and the sheet says so.

use super::data::RunData;
use super::draw;
use super::overlay::{boxes_at, draw_boxes};
use crate::geom::JointBox;
use image::{imageops, Rgb, RgbImage};

/// Frame spacing of the sheet when the run has no segment files.
pub const EVERY_NTH: u64 = 150;
/// Tile width, px (smaller frames are not enlarged).
const TILE_W: u32 = 320;
const PAD: u32 = 8;
const HEAD: u32 = 28;

/// One tile to cut from the clip: the frame, its caption and the rectangles to draw.
#[derive(Debug, Clone)]
pub struct TileSpec {
    pub frame: u64,
    pub caption: String,
    pub boxes: Vec<(String, JointBox, String)>,
}

/// The tiles of a run's sheet and its header line.
pub fn plan(data: &RunData) -> (Vec<TileSpec>, String) {
    if data.segments.is_empty() {
        let tiles: Vec<TileSpec> = (data.first..data.end())
            .step_by(EVERY_NTH as usize)
            .map(|f| TileSpec {
                frame: f,
                caption: format!("frame {f}"),
                boxes: boxes_at(data, f),
            })
            .collect();
        let head = format!(
            "no segments/ folder: every {EVERY_NTH}th tracked frame ({} tiles) with its tracked rectangles",
            tiles.len()
        );
        return (tiles, head);
    }
    let tiles = (0..data.segments.len())
        .map(|k| {
            let s = &data.segments[k];
            let (a, b) = data.segment_range(k);
            let flags = data.flags(a, b);
            TileSpec {
                frame: s.seeds.frame,
                caption: format!("{} f{} {}", s.id, s.seeds.frame, flags.describe()),
                boxes: s
                    .seeds
                    .joints
                    .iter()
                    .map(|j| {
                        let st = j.status.clone().unwrap_or_else(|| "seed".into());
                        (j.name.clone(), j.bbox, st)
                    })
                    .collect(),
            }
        })
        .collect::<Vec<_>>();
    let head = format!(
        "{} segments: first frame of each with its segment file's rectangles",
        tiles.len()
    );
    (tiles, head)
}

/// A tile: `frame` with the spec's rectangles, scaled to the tile width, captioned.
pub fn tile(frame: &RgbImage, spec: &TileSpec, data: &RunData) -> RgbImage {
    let mut img = frame.clone();
    let shrink = (img.width() as f32 / TILE_W as f32).max(1.0);
    let thick = shrink.round().max(1.0) as u32;
    draw_boxes(&mut img, data, &spec.boxes, thick, 1, false);
    let tw = img.width().min(TILE_W);
    let th = ((img.height() as f32 * tw as f32 / img.width() as f32).round() as u32).max(1);
    let mut t = if tw == img.width() {
        img
    } else {
        imageops::resize(&img, tw, th, imageops::FilterType::Triangle)
    };
    draw::label(&mut t, 1, 1, &spec.caption, draw::WHITE, 1);
    t
}

/// Lays `tiles` out in a grid under a header line.
pub fn compose(tiles: &[RgbImage], head: &str) -> RgbImage {
    let cols = if tiles.len() > 24 {
        6
    } else {
        tiles.len().clamp(1, 4)
    } as u32;
    let (tw, th) = tiles.iter().fold((TILE_W.min(200), 1), |(w, h), t| {
        (w.max(t.width()), h.max(t.height()))
    });
    let rows = (tiles.len() as u32).div_ceil(cols).max(1);
    let w = (PAD + cols * (tw + PAD)).max(draw::text_width(head, 1) + 2 * PAD);
    let h = HEAD + rows * (th + PAD) + PAD;
    let mut img = RgbImage::from_pixel(w, h, Rgb([32, 32, 32]));
    draw::text(&mut img, PAD as i32, 10, head, draw::WHITE, 1);
    for (i, t) in tiles.iter().enumerate() {
        let (c, r) = (i as u32 % cols, i as u32 / cols);
        let (x, y) = (PAD + c * (tw + PAD), HEAD + r * (th + PAD));
        imageops::replace(&mut img, t, x as i64, y as i64);
    }
    img
}
