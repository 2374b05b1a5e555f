//! BlazePose's two networks around their tensors (docs/method.md §2.8): the person detector's
//! anchors and boxes, the rotated square region of interest (ROI) a body is cropped to, and the
//! landmark network's 39 points refined on its heatmaps, mapped back to the frame.
//!
//! The numbers (anchor layout, 1.25 ROI margin, 7-cell heatmap window, 0.5 refinement
//! threshold) are those of the networks' own graph, which the models were trained with.

use crate::geom::{Point, Vector};
use image::RgbImage;

/// Side of the detector's square input (px).
pub const DETECTOR_SIDE: usize = 224;
/// Side of the landmark network's square input (px).
pub const LANDMARK_SIDE: usize = 256;
/// Body landmarks the landmark network gives (then two alignment points and four more).
pub const LANDMARKS: usize = 33;
/// Points in the landmark network's output, each `x, y, z, visibility, presence`.
const RAW_POINTS: usize = 39;
/// The two alignment points of the landmark output: hip centre and a point on the circle
/// around the body.
const ALIGN_CENTRE: usize = 33;
const ALIGN_SCALE: usize = 34;
/// The heatmap's side and the refinement window (cells).
const HEATMAP_SIDE: usize = 64;
const HEATMAP_KERNEL: usize = 7;
const HEATMAP_MIN_CONFIDENCE: f32 = 0.5;
/// A detection counts from this score (after the sigmoid).
pub const MIN_DETECTION_SCORE: f32 = 0.5;

/// A rotated square of the frame the landmark network looks at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Roi {
    pub centre: Point,
    /// Side (px).
    pub side: f32,
    /// Rotation (radians, clockwise on screen) that stands the body upright in the crop.
    pub rotation: f32,
    /// The crop is the mirror image of the region (left and right swapped).
    pub mirrored: bool,
}

impl Roi {
    /// The ROI of a body from its two alignment points: the hip centre and a point at the
    /// body's radius, upright when the second is straight above the first, with a 25 % margin.
    pub fn from_alignment(centre: Point, scale_point: Point) -> Roi {
        let d = scale_point - centre;
        // The body is upright when the scale point is above the hips (angle -π/2).
        let rotation = normalize(std::f32::consts::FRAC_PI_2 + d.y.atan2(d.x));
        Roi {
            centre,
            side: 2.0 * d.norm() * 1.25,
            rotation,
            mirrored: false,
        }
    }

    /// The same region, its crop mirrored.
    pub fn mirror(self) -> Roi {
        Roi {
            mirrored: !self.mirrored,
            ..self
        }
    }

    /// Frame position of a point of the crop (crop px, 0..LANDMARK_SIDE).
    pub fn to_frame(&self, u: f32, v: f32) -> Point {
        let k = self.side / LANDMARK_SIDE as f32;
        let u = if self.mirrored {
            LANDMARK_SIDE as f32 - u
        } else {
            u
        };
        let (s, c) = self.rotation.sin_cos();
        let (du, dv) = (
            (u - LANDMARK_SIDE as f32 / 2.0) * k,
            (v - LANDMARK_SIDE as f32 / 2.0) * k,
        );
        Point::new(
            self.centre.x + c * du - s * dv,
            self.centre.y + s * du + c * dv,
        )
    }

    /// The crop the landmark network takes: RGB in [0, 1], row-major HWC, bilinear, black
    /// outside the frame.
    pub fn crop(&self, img: &RgbImage) -> Vec<f32> {
        let n = LANDMARK_SIDE;
        let mut out = vec![0f32; n * n * 3];
        for v in 0..n {
            for u in 0..n {
                let p = self.to_frame(u as f32 + 0.5, v as f32 + 0.5);
                let px = bilinear(img, p.x - 0.5, p.y - 0.5);
                let o = (v * n + u) * 3;
                out[o..o + 3].copy_from_slice(&px);
            }
        }
        out
    }
}

/// Wraps an angle into [-π, π).
fn normalize(a: f32) -> f32 {
    use std::f32::consts::PI;
    a - 2.0 * PI * ((a + PI) / (2.0 * PI)).floor()
}

/// The pixel at a frame position whose pixel centres lie on whole numbers, in [0, 1].
fn bilinear(img: &RgbImage, x: f32, y: f32) -> [f32; 3] {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let mut acc = [0f32; 3];
    for (dx, dy, wgt) in [
        (0, 0, (1.0 - fx) * (1.0 - fy)),
        (1, 0, fx * (1.0 - fy)),
        (0, 1, (1.0 - fx) * fy),
        (1, 1, fx * fy),
    ] {
        let (xx, yy) = (x0 + dx, y0 + dy);
        if wgt == 0.0 || xx < 0 || yy < 0 || xx >= w || yy >= h {
            continue;
        }
        let p = img.get_pixel(xx as u32, yy as u32).0;
        for c in 0..3 {
            acc[c] += wgt * p[c] as f32 / 255.0;
        }
    }
    acc
}

fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x.clamp(-100.0, 100.0)).exp())
}

/// One person the detector found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detection {
    pub score: f32,
    /// The box around the person (px): top-left corner and size.
    pub min: Point,
    pub size: Vector,
    /// Hip centre and the point on the circle around the body (px).
    pub centre: Point,
    pub scale_point: Point,
}

impl Detection {
    pub fn roi(&self) -> Roi {
        Roi::from_alignment(self.centre, self.scale_point)
    }

    pub fn area(&self) -> f32 {
        self.size.x * self.size.y
    }

    fn iou(&self, o: &Detection) -> f32 {
        let x0 = self.min.x.max(o.min.x);
        let y0 = self.min.y.max(o.min.y);
        let x1 = (self.min.x + self.size.x).min(o.min.x + o.size.x);
        let y1 = (self.min.y + self.size.y).min(o.min.y + o.size.y);
        let inter = (x1 - x0).max(0.0) * (y1 - y0).max(0.0);
        inter / (self.area() + o.area() - inter).max(1e-6)
    }
}

/// The frame letterboxed into the detector's square input: RGB in [-1, 1], HWC, and the
/// square's side and offset in the frame (px), to map boxes back.
pub fn detector_input(img: &RgbImage) -> (Vec<f32>, f32, Vector) {
    let side = img.width().max(img.height()) as f32;
    let offset = Vector::new(
        (side - img.width() as f32) / 2.0,
        (side - img.height() as f32) / 2.0,
    );
    let n = DETECTOR_SIDE;
    let k = side / n as f32;
    let mut out = vec![0f32; n * n * 3];
    for v in 0..n {
        for u in 0..n {
            let x = (u as f32 + 0.5) * k - offset.x;
            let y = (v as f32 + 0.5) * k - offset.y;
            let px = bilinear(img, x - 0.5, y - 0.5);
            let o = (v * n + u) * 3;
            for c in 0..3 {
                out[o + c] = px[c] * 2.0 - 1.0;
            }
        }
    }
    (out, side, offset)
}

/// The detector's anchors (centres in [0, 1]): two per cell of a 28×28, a 14×14 and three 7×7
/// grids.
fn anchors() -> Vec<(f32, f32)> {
    let mut out = Vec::with_capacity(2254);
    for (cells, per_cell) in [(28usize, 2usize), (14, 2), (7, 6)] {
        for y in 0..cells {
            for x in 0..cells {
                for _ in 0..per_cell {
                    out.push((
                        (x as f32 + 0.5) / cells as f32,
                        (y as f32 + 0.5) / cells as f32,
                    ));
                }
            }
        }
    }
    out
}

/// The people in the detector's outputs (`boxes`: 12 numbers an anchor, `scores`: one),
/// strongest first, overlapping boxes of one person merged away.
pub fn decode_detections(
    boxes: &[f32],
    scores: &[f32],
    side: f32,
    offset: Vector,
) -> Vec<Detection> {
    let anchors = anchors();
    let n = DETECTOR_SIDE as f32;
    let to_frame = |x: f32, y: f32| Point::new(x * side - offset.x, y * side - offset.y);
    let mut found: Vec<Detection> = Vec::new();
    for (i, &(ax, ay)) in anchors.iter().enumerate() {
        let Some(&raw) = scores.get(i) else { break };
        let score = sigmoid(raw);
        if score < MIN_DETECTION_SCORE {
            continue;
        }
        let r = &boxes[i * 12..i * 12 + 12];
        let (cx, cy, w, h) = (r[0] / n + ax, r[1] / n + ay, r[2] / n, r[3] / n);
        found.push(Detection {
            score,
            min: to_frame(cx - w / 2.0, cy - h / 2.0),
            size: Vector::new(w * side, h * side),
            centre: to_frame(r[4] / n + ax, r[5] / n + ay),
            scale_point: to_frame(r[6] / n + ax, r[7] / n + ay),
        });
    }
    found.sort_by(|a, b| b.score.total_cmp(&a.score));
    let mut kept: Vec<Detection> = Vec::new();
    for d in found {
        if kept.iter().all(|k| k.iou(&d) < 0.3) {
            kept.push(d);
        }
    }
    kept
}

/// One landmark in the frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Landmark {
    pub pos: Point,
    /// How likely the point is in view and not hidden by the body, in [0, 1].
    pub visibility: f32,
    /// How likely the point is inside the crop, in [0, 1].
    pub presence: f32,
}

/// The landmark network's answer for one crop.
#[derive(Debug, Clone, PartialEq)]
pub struct Landmarks {
    pub points: Vec<Landmark>,
    /// How sure the network is that a person fills the crop, in [0, 1].
    pub person: f32,
    /// The ROI of the next frame, from this frame's alignment points.
    pub next_roi: Roi,
}

/// Decodes the landmark network's outputs for the crop `roi`: `raw` (39 × 5 numbers in crop
/// px), `person` (one logit) and `heatmap` (64 × 64 × 39 logits, HWC). Each point is moved to
/// the weighted mean of its heatmap around it where the heatmap is sure of it.
pub fn decode_landmarks(raw: &[f32], person: f32, heatmap: &[f32], roi: &Roi) -> Landmarks {
    let mut pts: Vec<(f32, f32, f32, f32)> = (0..RAW_POINTS)
        .map(|i| {
            let r = &raw[i * 5..i * 5 + 5];
            (r[0], r[1], sigmoid(r[3]), sigmoid(r[4]))
        })
        .collect();
    if heatmap.len() == HEATMAP_SIDE * HEATMAP_SIDE * RAW_POINTS {
        for (i, p) in pts.iter_mut().enumerate() {
            if let Some((x, y)) = refine_on_heatmap(heatmap, i, p.0, p.1) {
                p.0 = x;
                p.1 = y;
            }
        }
    }
    let mut points: Vec<Landmark> = pts[..LANDMARKS]
        .iter()
        .map(|&(u, v, vis, pres)| Landmark {
            pos: roi.to_frame(u, v),
            visibility: vis,
            presence: pres,
        })
        .collect();
    if roi.mirrored {
        // The network named the sides of a mirror image.
        let named: Vec<Landmark> = points.clone();
        for (i, p) in points.iter_mut().enumerate() {
            *p = named[super::names::mirror(i)];
        }
    }
    let (c, s) = (pts[ALIGN_CENTRE], pts[ALIGN_SCALE]);
    Landmarks {
        points,
        person: sigmoid(person),
        next_roi: Roi {
            mirrored: roi.mirrored,
            ..Roi::from_alignment(roi.to_frame(c.0, c.1), roi.to_frame(s.0, s.1))
        },
    }
}

/// Point `i` (crop px) moved to its heatmap's confidence-weighted mean over the window around
/// it, when the window's peak confidence reaches the threshold.
fn refine_on_heatmap(heatmap: &[f32], i: usize, u: f32, v: f32) -> Option<(f32, f32)> {
    let n = HEATMAP_SIDE as i64;
    let cell = LANDMARK_SIDE as f32 / HEATMAP_SIDE as f32;
    let (col, row) = ((u / cell).floor() as i64, (v / cell).floor() as i64);
    if col < 0 || col >= n || row < 0 || row >= n {
        return None;
    }
    let r = (HEATMAP_KERNEL as i64 - 1) / 2;
    let (mut sum, mut wc, mut wr, mut peak) = (0f32, 0f32, 0f32, 0f32);
    for y in (row - r).max(0)..(row + r + 1).min(n) {
        for x in (col - r).max(0)..(col + r + 1).min(n) {
            let c = sigmoid(heatmap[((y * n + x) as usize) * RAW_POINTS + i]);
            sum += c;
            peak = peak.max(c);
            // A cell's index, not its centre: the network's heatmap is laid out that way.
            wc += x as f32 * c;
            wr += y as f32 * c;
        }
    }
    (peak >= HEATMAP_MIN_CONFIDENCE && sum > 0.0).then(|| (wc / sum * cell, wr / sum * cell))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_anchors_are_the_detectors_2254() {
        let a = anchors();
        assert_eq!(a.len(), 2254);
        assert_eq!(a[0], (0.5 / 28.0, 0.5 / 28.0));
        assert_eq!(a[2253], (6.5 / 7.0, 6.5 / 7.0));
    }

    #[test]
    fn an_upright_roi_maps_the_crop_centre_to_the_hips() {
        let roi = Roi::from_alignment(Point::new(100.0, 200.0), Point::new(100.0, 100.0));
        assert!(roi.rotation.abs() < 1e-6);
        assert!((roi.side - 250.0).abs() < 1e-3);
        let c = roi.to_frame(128.0, 128.0);
        assert!((c - Point::new(100.0, 200.0)).norm() < 1e-3);
        // The crop's top edge is 125 px above the hips.
        assert!((roi.to_frame(128.0, 0.0).y - 75.0).abs() < 1e-3);
    }

    #[test]
    fn a_lying_body_is_turned_upright() {
        // Scale point to the right of the hips: the body lies along +x; the crop's up (-v)
        // must point along +x in the frame.
        let roi = Roi::from_alignment(Point::new(0.0, 0.0), Point::new(100.0, 0.0));
        let up = roi.to_frame(128.0, 0.0) - roi.to_frame(128.0, 128.0);
        assert!(up.x > 100.0 && up.y.abs() < 1e-3, "{up:?}");
    }

    #[test]
    fn a_mirrored_crop_maps_its_left_edge_to_the_regions_right() {
        let roi = Roi::from_alignment(Point::new(100.0, 200.0), Point::new(100.0, 100.0));
        let m = roi.mirror();
        assert!((m.to_frame(0.0, 128.0) - roi.to_frame(256.0, 128.0)).norm() < 1e-3);
        assert!((m.to_frame(128.0, 128.0) - roi.to_frame(128.0, 128.0)).norm() < 1e-3);
    }

    #[test]
    fn the_heatmap_pulls_a_point_to_its_peak() {
        let mut hm = vec![-10f32; HEATMAP_SIDE * HEATMAP_SIDE * RAW_POINTS];
        // A sure peak for point 5 on cell (20, 30).
        hm[(30 * HEATMAP_SIDE + 20) * RAW_POINTS + 5] = 10.0;
        let (x, y) = refine_on_heatmap(&hm, 5, 19.0 * 4.0, 31.0 * 4.0).unwrap();
        assert!((x - 20.0 * 4.0).abs() < 0.01 && (y - 30.0 * 4.0).abs() < 0.01);
        // Unsure everywhere: the point stays.
        assert!(refine_on_heatmap(&hm, 6, 19.0 * 4.0, 31.0 * 4.0).is_none());
    }
}
