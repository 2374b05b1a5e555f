//! Drawing: the background, the character's parts as anti-aliased shapes, sensor noise, and
//! which part is in front where.
//!
//! Every part is a signed distance field in px (negative inside). Coverage of a pixel is
//! `clamp(0.5 − d, 0, 1)` at its centre, which is the exact area for straight edges and
//! changes continuously with sub-pixel motion; patterns use the same 1-px ramps, so texture
//! moves smoothly too. Parts are composited back to front in `f32`, then rounded once.

use image::RgbImage;

use super::character::{Look, Part, PartShape, Pattern, JOINT_RADIUS, PARTS};
use super::character::{LEFT, RIGHT};
use super::motion::{Kinematics, Pose};
use super::{splitmix64, Rng};
use crate::geom::Vector;

/// An RGB colour, 0–255 per channel, as `f32` while compositing.
pub type Colour = [f32; 3];

/// The geometry of a placed part (px).
#[derive(Debug, Clone, Copy)]
pub enum Geom {
    /// Tapered capsule from `a` (radius `ra`) to `b` (radius `rb`).
    Capsule {
        a: Vector,
        b: Vector,
        ra: f32,
        rb: f32,
    },
    /// Disc.
    Disc { c: Vector, r: f32 },
}

/// A part placed on one frame.
#[derive(Debug, Clone, Copy)]
pub struct Shape {
    pub geom: Geom,
    /// Origin of the texture frame (px).
    pub origin: Vector,
    /// Unit vector along the bone (texture `u`).
    pub u_dir: Vector,
    /// +1 or −1: mirrors texture `v` with the character so patterns stay on their side.
    pub v_sign: f32,
    /// Texture `u` is divided by this (the bone's stretch), so patterns stretch with it.
    pub stretch: f32,
    pub look: Look,
    /// Pattern period (px).
    pub period: f32,
    /// Outline width (px).
    pub outline: f32,
    /// Flat cartoon colours: no pattern and no shading.
    pub flat: bool,
    /// The joints this part shows (its bone's ends).
    pub joints: [usize; 2],
}

impl Geom {
    /// Signed distance (px) from `p` to the outline, negative inside.
    #[inline]
    pub fn sdf(&self, p: Vector) -> f32 {
        match *self {
            Geom::Disc { c, r } => (p - c).norm() - r,
            Geom::Capsule { a, b, ra, rb } => uneven_capsule(p - a, b - a, ra, rb),
        }
    }

    /// Bounding box `(x0, y0, x1, y1)` in px, one px of slack around the shape.
    fn bounds(&self) -> (f32, f32, f32, f32) {
        match *self {
            Geom::Disc { c, r } => (c.x - r - 1.0, c.y - r - 1.0, c.x + r + 1.0, c.y + r + 1.0),
            Geom::Capsule { a, b, ra, rb } => {
                let r = ra.max(rb) + 1.0;
                (
                    a.x.min(b.x) - r,
                    a.y.min(b.y) - r,
                    a.x.max(b.x) + r,
                    a.y.max(b.y) + r,
                )
            }
        }
    }
}

/// Exact signed distance to a capsule from the origin to `b` with end radii `ra`, `rb`
/// (after Inigo Quilez's "uneven capsule"); degenerates to a disc when one end swallows the
/// other.
fn uneven_capsule(p: Vector, b: Vector, ra: f32, rb: f32) -> f32 {
    let h = b.norm_squared();
    let dr = ra - rb;
    if h <= dr * dr + 1e-6 {
        return if ra >= rb {
            p.norm() - ra
        } else {
            (p - b).norm() - rb
        };
    }
    let q = Vector::new((p.x * b.y - p.y * b.x).abs(), p.dot(&b)) / h;
    let c = Vector::new((h - dr * dr).sqrt(), dr);
    let k = c.x * q.y - c.y * q.x;
    let m = c.dot(&q);
    let n = q.norm_squared();
    if k < 0.0 {
        (h * n).sqrt() - ra
    } else if k > c.x {
        (h * (n + 1.0 - 2.0 * q.y)).max(0.0).sqrt() - rb
    } else {
        m - ra
    }
}

/// The parts of one frame, back to front: far arm, far leg, torso, neck, head, near leg, near
/// arm. `joints` are the joint positions (px); `kin` gives bone directions.
pub fn scene(pose: &Pose, kin: &Kinematics, joints: &[Vector], hc: f32, flat: bool) -> Vec<Shape> {
    let (near, far) = if pose.facing >= 0.0 {
        (LEFT, RIGHT)
    } else {
        (RIGHT, LEFT)
    };
    let v_sign = if pose.facing >= 0.0 { 1.0 } else { -1.0 };
    let limb = |side: usize, names: &[&str]| -> Vec<&'static Part> {
        names
            .iter()
            .map(|n| {
                PARTS
                    .iter()
                    .find(|p| p.name.starts_with(n) && p.side == Some(side))
                    // Cannot fail: PARTS is a constant table holding every name asked for.
                    .expect("part table")
            })
            .collect()
    };
    // Cannot fail: PARTS is a constant table holding every name asked for.
    let by_name = |n: &str| PARTS.iter().find(|p| p.name == n).expect("part table");
    let arm = ["hand", "forearm", "upper_arm"];
    let leg = ["foot", "shin", "thigh"];
    let mut order: Vec<&Part> = Vec::with_capacity(PARTS.len());
    order.extend(limb(far, &arm));
    order.extend(limb(far, &leg));
    order.extend([by_name("torso"), by_name("neck"), by_name("head")]);
    order.extend(limb(near, &leg));
    order.extend(limb(near, &arm));

    let outline = (0.0065 * hc).max(0.8);
    order
        .into_iter()
        .map(|part| {
            let stretch = pose.scale[part.b];
            let thin = 1.0 / stretch.sqrt();
            let (a, b) = (joints[part.a], joints[part.b]);
            let u_dir = kin.dir[part.b];
            let geom = match part.shape {
                PartShape::Capsule => Geom::Capsule {
                    a,
                    b,
                    ra: part.ra * hc * thin,
                    rb: part.rb * hc * thin,
                },
                PartShape::Disc => Geom::Disc {
                    c: b,
                    r: part.rb * hc,
                },
                PartShape::Fist => {
                    let off = 0.022 * hc;
                    let c = b + Vector::new(pose.facing * v_sign * u_dir.x, u_dir.y) * off;
                    Geom::Disc {
                        c,
                        r: part.rb * hc * thin,
                    }
                }
            };
            Shape {
                geom,
                origin: if part.shape == PartShape::Capsule {
                    a
                } else {
                    b
                },
                u_dir,
                v_sign,
                stretch,
                look: part.look,
                period: (part.look.period * hc).max(3.0),
                outline,
                flat,
                joints: [part.a, part.b],
            }
        })
        .collect()
}

/// A band indicator along `x` with period `p` px: 1 on half of each period, 0 on the other, with
/// 1-px ramps between.
#[inline]
fn band(x: f32, p: f32) -> f32 {
    let q = ((x / p).rem_euclid(1.0) - 0.5).abs() * p;
    (0.25 * p - q + 0.5).clamp(0.0, 1.0)
}

#[inline]
fn mix(a: Colour, b: Colour, w: f32) -> Colour {
    [
        a[0] + (b[0] - a[0]) * w,
        a[1] + (b[1] - a[1]) * w,
        a[2] + (b[2] - a[2]) * w,
    ]
}

impl Shape {
    /// The colour at `p` (px) where the signed distance is `d` (px).
    #[inline]
    fn colour(&self, p: Vector, d: f32) -> Colour {
        let rel = p - self.origin;
        let u = rel.dot(&self.u_dir);
        let v = (self.u_dir.x * rel.y - self.u_dir.y * rel.x) * self.v_sign;
        let look = &self.look;
        let per = self.period;
        let mut c = match (look.pattern, self.flat) {
            (Pattern::Face, _) => {
                let r = match self.geom {
                    Geom::Disc { r, .. } => r,
                    Geom::Capsule { ra, .. } => ra,
                };
                // Hair over the top and back, an eye at the front.
                let hair = (0.6 * u - 0.8 * v - 0.12 * r + 0.5).clamp(0.0, 1.0);
                let mut c = mix(look.fill, look.accent, hair);
                let eye = (0.13 * r - (Vector::new(u - 0.12 * r, v - 0.5 * r)).norm() + 0.5)
                    .clamp(0.0, 1.0);
                c = mix(c, [28.0, 24.0, 36.0], eye);
                let mouth = (0.05 * r + 0.5 - (u + 0.42 * r).abs()).clamp(0.0, 1.0)
                    * (0.5 + 0.4 * r - (v - 0.55 * r).abs() * 2.5).clamp(0.0, 1.0);
                mix(c, [150.0, 60.0, 60.0], mouth)
            }
            (_, true) | (Pattern::Flat, _) => look.fill,
            (pattern, false) => {
                let u = u / self.stretch;
                let w = match pattern {
                    Pattern::Bands => band(u, per),
                    Pattern::Stripes => band(v + 0.25 * per, 0.5 * per),
                    Pattern::Checks => {
                        let (a, b) = (band(u, per), band(v + 0.25 * per, per));
                        a + b - 2.0 * a * b
                    }
                    Pattern::Dots => {
                        let row = (u / per).floor();
                        let shift = if row.rem_euclid(2.0) == 0.0 { 0.0 } else { 0.5 };
                        let du = ((u / per).rem_euclid(1.0) - 0.5) * per;
                        let dv = ((v / per + shift).rem_euclid(1.0) - 0.5) * per;
                        (0.27 * per - (du * du + dv * dv).sqrt() + 0.5).clamp(0.0, 1.0)
                    }
                    Pattern::Diagonal => band(std::f32::consts::FRAC_1_SQRT_2 * (u + v), 0.7 * per),
                    Pattern::Chevrons => band(u + 0.9 * v.abs(), per),
                    Pattern::Flat | Pattern::Face => 0.0,
                };
                mix(look.fill, look.accent, w)
            }
        };
        if !self.flat {
            // Soft shading across the limb, lit from the character's front-top.
            let shade = 1.0 + 0.1 * (v.clamp(-per, per) / per);
            c = [c[0] * shade, c[1] * shade, c[2] * shade];
        }
        let line = (d + self.outline + 0.5).clamp(0.0, 1.0);
        let dark = [look.fill[0] * 0.4, look.fill[1] * 0.4, look.fill[2] * 0.4];
        mix(c, dark, line)
    }

    /// Composites the shape over `buf` (`width × height`, row-major).
    pub fn draw(&self, buf: &mut [Colour], width: u32, height: u32) {
        // Work in 8×8 blocks and skip a block when its centre is farther from the shape than
        // the block's half-diagonal plus the anti-aliasing ramp (the distance is 1-Lipschitz).
        const BLOCK: usize = 8;
        let reach = (BLOCK as f32 - 1.0) * std::f32::consts::FRAC_1_SQRT_2 + 0.5;
        let (x0, y0, x1, y1) = self.geom.bounds();
        let (w, h) = (width as usize, height as usize);
        let xs = x0.floor().max(0.0) as usize;
        let ys = y0.floor().max(0.0) as usize;
        let xe = (x1.ceil().max(0.0) as usize + 1).min(w);
        let ye = (y1.ceil().max(0.0) as usize + 1).min(h);
        for by in (ys..ye).step_by(BLOCK) {
            let bye = (by + BLOCK).min(ye);
            for bx in (xs..xe).step_by(BLOCK) {
                let bxe = (bx + BLOCK).min(xe);
                let centre = Vector::new(0.5 * (bx + bxe - 1) as f32, 0.5 * (by + bye - 1) as f32);
                if self.geom.sdf(centre) > reach {
                    continue;
                }
                for y in by..bye {
                    let row = &mut buf[y * w + bx..y * w + bxe];
                    for (i, px) in row.iter_mut().enumerate() {
                        let p = Vector::new((bx + i) as f32, y as f32);
                        let d = self.geom.sdf(p);
                        if d >= 0.5 {
                            continue;
                        }
                        let cover = (0.5 - d).min(1.0);
                        let c = self.colour(p, d);
                        *px = mix(*px, c, cover);
                    }
                }
            }
        }
    }
}

/// Fraction of each joint's articulation disc (half its limb radius) that shows a part of one
/// of its own bones on top: 1 = fully visible, 0 = hidden (or only background).
pub fn visibility(shapes: &[Shape], joints: &[Vector], hc: f32) -> Vec<f32> {
    const RING: usize = 8;
    joints
        .iter()
        .enumerate()
        .map(|(j, &c)| {
            let r = 0.5 * JOINT_RADIUS[j] * hc;
            let mut seen = 0;
            for k in 0..=RING {
                let p = if k == RING {
                    c
                } else {
                    let a = k as f32 * std::f32::consts::TAU / RING as f32;
                    c + Vector::new(a.cos(), a.sin()) * r
                };
                if let Some(top) = shapes.iter().rev().find(|s| s.geom.sdf(p) < 0.0) {
                    if top.joints.contains(&j) {
                        seen += 1;
                    }
                }
            }
            seen as f32 / (RING + 1) as f32
        })
        .collect()
}

/// Lattice value noise in [−1, 1] with cell size `cell` px.
fn value_noise(seed: u64, x: f32, y: f32, cell: f32) -> f32 {
    let (gx, gy) = (x / cell, y / cell);
    let (ix, iy) = (gx.floor(), gy.floor());
    let (fx, fy) = (gx - ix, gy - iy);
    let (sx, sy) = (fx * fx * (3.0 - 2.0 * fx), fy * fy * (3.0 - 2.0 * fy));
    let at = |dx: i64, dy: i64| {
        let h = splitmix64(
            seed ^ ((ix as i64 + dx) as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
                ^ ((iy as i64 + dy) as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F),
        );
        (h >> 40) as f32 / (1u64 << 23) as f32 - 1.0
    };
    let top = at(0, 0) + (at(1, 0) - at(0, 0)) * sx;
    let bottom = at(0, 1) + (at(1, 1) - at(0, 1)) * sx;
    top + (bottom - top) * sy
}

/// The static backdrop (`width × height`, row-major): a sky-to-floor gradient with a soft
/// horizon, a faint floor pattern, value noise and soft colour blobs. Mid-tone and muted so
/// the limbs stand out without the backdrop being flat.
pub fn background(width: u32, height: u32, seed: u64) -> Vec<Colour> {
    let mut rng = Rng::new(seed ^ 0xB4C6_0000_0000_0001);
    let (w, h) = (width as f32, height as f32);
    let jitter = |rng: &mut Rng, c: [f32; 3], a: f32| {
        [
            c[0] + rng.range(-a, a),
            c[1] + rng.range(-a, a),
            c[2] + rng.range(-a, a),
        ]
    };
    let sky_top = jitter(&mut rng, [150.0, 168.0, 188.0], 14.0);
    let sky_low = jitter(&mut rng, [194.0, 196.0, 186.0], 10.0);
    let floor_far = jitter(&mut rng, [160.0, 150.0, 128.0], 12.0);
    let floor_near = jitter(&mut rng, [128.0, 116.0, 98.0], 12.0);
    let horizon = h * rng.range(0.56, 0.64);
    let noise_seed = rng.next_u64();
    let blobs: Vec<(f32, f32, f32, Colour)> = (0..12)
        .map(|_| {
            let (cx, cy) = (rng.range(0.0, w), rng.range(0.0, h));
            let sigma = h * rng.range(0.05, 0.16);
            let c = [
                rng.range(-22.0, 22.0),
                rng.range(-22.0, 22.0),
                rng.range(-22.0, 22.0),
            ];
            (cx, cy, sigma, c)
        })
        .collect();
    let tile = h * rng.range(0.09, 0.13);
    let mut buf = vec![[0.0f32; 3]; (width * height) as usize];
    for y in 0..height {
        let yf = y as f32;
        let sky = mix(sky_top, sky_low, (yf / horizon).clamp(0.0, 1.0).powf(1.3));
        let depth = ((yf - horizon) / (h - horizon)).clamp(0.0, 1.0);
        let ground = mix(floor_far, floor_near, depth);
        let to_ground = ((yf - horizon) / (0.015 * h) + 0.5).clamp(0.0, 1.0);
        let base = mix(sky, ground, to_ground);
        for x in 0..width {
            let xf = x as f32;
            let mut c = base;
            // Floor tiles in perspective: faint, fading out towards the horizon.
            if depth > 0.0 {
                let z = 1.0 / (depth + 0.1);
                let xw = (xf - 0.5 * w) * z / tile;
                let t = 6.0 * (4.0 * depth).min(1.0) * (xw * 0.5).sin() * (z * 2.2).sin();
                c = [c[0] + t, c[1] + t, c[2] + t];
            }
            let n = 11.0 * value_noise(noise_seed, xf, yf, 0.2 * h)
                + 6.0 * value_noise(noise_seed ^ 1, xf, yf, 0.07 * h)
                + 3.0 * value_noise(noise_seed ^ 2, xf, yf, 0.025 * h);
            let tint = 4.0 * value_noise(noise_seed ^ 3, xf, yf, 0.3 * h);
            c = [c[0] + n + tint, c[1] + n, c[2] + n - tint];
            for &(cx, cy, s, bc) in &blobs {
                let d2 = ((xf - cx) * (xf - cx) + (yf - cy) * (yf - cy)) / (s * s);
                if d2 < 9.0 {
                    let g = (-0.5 * d2).exp();
                    c = [c[0] + g * bc[0], c[1] + g * bc[1], c[2] + g * bc[2]];
                }
            }
            buf[(y * width + x) as usize] = c;
        }
    }
    buf
}

/// Sensor noise for one frame: global gain (flicker) and per-pixel noise σ (levels).
#[derive(Debug, Clone, Copy)]
pub struct Noise {
    pub seed: u64,
    pub gain: f32,
    pub sigma: f32,
}

/// Rounds `buf` into an image, applying `noise` if any.
pub fn to_image(buf: &[Colour], width: u32, height: u32, noise: Option<Noise>) -> RgbImage {
    let mut raw = vec![0u8; buf.len() * 3];
    match noise {
        None => {
            for (out, c) in raw.chunks_exact_mut(3).zip(buf) {
                for ch in 0..3 {
                    out[ch] = (c[ch] + 0.5).clamp(0.0, 255.0) as u8;
                }
            }
        }
        Some(n) => {
            // Per channel, the sum of three 7-bit uniforms from one hash a pixel: near-Gaussian,
            // mean 190.5, standard deviation 64.
            let k = n.sigma / 64.0;
            for (i, (out, c)) in raw.chunks_exact_mut(3).zip(buf).enumerate() {
                let r = splitmix64(n.seed ^ (i as u64).wrapping_mul(0x2545_F491_4F6C_DD1D));
                for ch in 0..3 {
                    let bits = r >> (ch * 21);
                    let sum = (bits & 0x7F) + ((bits >> 7) & 0x7F) + ((bits >> 14) & 0x7F);
                    let v = c[ch] * n.gain + (sum as f32 - 190.5) * k;
                    out[ch] = (v + 0.5).clamp(0.0, 255.0) as u8;
                }
            }
        }
    }
    // Cannot fail: `raw` holds exactly width*height RGB pixels.
    RgbImage::from_raw(width, height, raw).expect("buffer matches the frame size")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn capsule_distance_matches_hand_values() {
        let g = Geom::Capsule {
            a: Vector::new(0.0, 0.0),
            b: Vector::new(10.0, 0.0),
            ra: 2.0,
            rb: 2.0,
        };
        assert!((g.sdf(Vector::new(5.0, 0.0)) + 2.0).abs() < 1e-5);
        assert!((g.sdf(Vector::new(5.0, 5.0)) - 3.0).abs() < 1e-5);
        assert!((g.sdf(Vector::new(-3.0, 0.0)) - 1.0).abs() < 1e-5);
        assert!((g.sdf(Vector::new(14.0, 0.0)) - 2.0).abs() < 1e-5);
    }

    #[test]
    fn band_covers_half_of_each_period() {
        let p = 8.0;
        let mean: f32 = (0..800).map(|i| band(i as f32 * 0.01, p)).sum::<f32>() / 800.0;
        assert!((mean - 0.5).abs() < 0.02, "{mean}");
    }

    #[test]
    fn sub_pixel_motion_changes_pixels() {
        let draw = |x: f32| {
            let mut buf = vec![[0.0f32; 3]; 20 * 20];
            let s = Shape {
                geom: Geom::Disc {
                    c: Vector::new(x, 10.0),
                    r: 4.0,
                },
                origin: Vector::new(x, 10.0),
                u_dir: Vector::new(1.0, 0.0),
                v_sign: 1.0,
                stretch: 1.0,
                look: PARTS[0].look,
                period: 5.0,
                outline: 1.0,
                flat: true,
                joints: [0, 0],
            };
            s.draw(&mut buf, 20, 20);
            buf
        };
        let (a, b) = (draw(10.0), draw(10.25));
        let diff: f32 = a.iter().zip(&b).map(|(p, q)| (p[0] - q[0]).abs()).sum();
        assert!(diff > 10.0, "{diff}");
    }
}
