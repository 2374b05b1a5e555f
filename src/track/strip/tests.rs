//! Unit tests of the strip: fit, gradient against finite differences, Gauss–Newton steps,
//! learning.

use super::*;
const LEVELS: usize = 3;
use crate::track::pixels::Pyramid;
use image::RgbImage;

/// A smooth 80×60 frame: a bar from `p` to `c`, 5 px half-width with soft edges, coloured
/// by a sine of the position along it (so it has texture to lock on).
fn smooth_bar(p: Point, c: Point) -> RgbImage {
    smooth_bar_scaled(p, c, 1.0)
}

/// [`smooth_bar`] drawn `k` times larger (frame, bar width, soft edge and texture).
fn smooth_bar_scaled(p: Point, c: Point, k: f32) -> RgbImage {
    RgbImage::from_fn((80.0 * k) as u32, (60.0 * k) as u32, |x, y| {
        let q = Point::new(x as f32, y as f32);
        let d = c - p;
        let t = (q - p).dot(&d) / d.norm_squared();
        let ext = Extent {
            a: p,
            b: c,
            ext_a: 0.0,
            ext_b: 0.0,
            half_width: 0.0,
        };
        let inside = ((5.0 * k - ext.distance(q)) / (3.0 * k)).clamp(0.0, 1.0);
        let phase = (t * 12.0).sin();
        let bar = [150.0 + 90.0 * phase, 120.0 - 80.0 * phase, 60.0];
        let bg = [90.0, 110.0, 130.0];
        image::Rgb([0, 1, 2].map(|k| (bg[k] + (bar[k] - bg[k]) * inside) as u8))
    })
}

fn spec() -> StripSpec {
    StripSpec {
        max_samples: 400,
        coarse_samples: 40,
        sigma: 12.0,
        width_exponent: 0.0,
    }
}

fn extent(p: Point, c: Point, ext: f32) -> Extent {
    Extent {
        a: p,
        b: c,
        ext_a: ext,
        ext_b: ext,
        half_width: 6.0,
    }
}

/// Level `k` of `pyr` as a view with no plate and no gain.
fn view<'a>(pyr: &'a Pyramid, k: usize) -> View<'a> {
    View {
        img: pyr.level(k),
        plate: None,
        gain: 1.0,
        bg_inv: 0.0,
    }
}

fn bone(img: &Pyramid, p: Point, c: Point, ext: f32) -> Strip {
    // Background: within 30 levels (L1) of the backdrop colour, as the plate test does.
    let bg = |x: f32, y: f32| {
        img.level(0).bilinear(x, y).map_or(f32::INFINITY, |c| {
            ((c[0] - 90.0).abs() + (c[1] - 110.0).abs() + (c[2] - 130.0).abs()) / 30.0
        })
    };
    Strip::sample(
        img,
        Shape::Bone,
        (0, 1),
        extent(p, c, ext),
        &spec(),
        &[],
        &bg,
    )
    .unwrap()
}

#[test]
fn fits_its_seed_pose_and_not_a_shifted_one() {
    let (p, c) = (Point::new(20.3, 30.4), Point::new(50.2, 30.1));
    let img = smooth_bar(p, c);
    let pyr = Pyramid::new(&img, LEVELS);
    let s = bone(&pyr, p, c, 3.0);
    let at_seed = s.fit(&view(&pyr, 0), p, c);
    assert!(at_seed.cost < 1e-3 && at_seed.inliers > 0.99, "{at_seed:?}");
    let off = Vector::new(0.0, 3.0);
    let shifted = s.fit(&view(&pyr, 0), p + off, c + off);
    assert!(shifted.inliers < 0.7, "{shifted:?}");
}

#[test]
fn the_gain_terms_measure_the_bar_darkened() {
    // The seed bar darkened by 6 %: the templates' least-squares gain over the samples that fit
    // is 0.94, whatever the view's gain the samples are chosen at (within the colour scale).
    let (p, c) = (Point::new(20.3, 30.4), Point::new(50.2, 30.1));
    let img = smooth_bar(p, c);
    let seed = Pyramid::new(&img, LEVELS);
    let s = bone(&seed, p, c, 3.0);
    let mut dark = smooth_bar(p, c);
    for px in dark.pixels_mut() {
        px.0 = px.0.map(|v| (v as f32 * 0.94).round() as u8);
    }
    let dark = Pyramid::new(&dark, LEVELS);
    for g in [1.0, 0.94, 0.9] {
        let v = View {
            gain: g,
            ..view(&dark, 0)
        };
        let (it, tt, _) = s.gain_terms(&v, p, c);
        assert!((it / tt - 0.94).abs() < 0.003, "chosen at {g}: {}", it / tt);
    }
    // A bar off its pose: little fits, little to measure.
    let off = Vector::new(0.0, 12.0);
    let (_, on, _) = s.gain_terms(&view(&dark, 0), p, c);
    let (_, away, _) = s.gain_terms(&view(&dark, 0), p + off, c + off);
    assert!(away < 0.1 * on, "{away} against {on}");
}

#[test]
fn gradient_matches_finite_differences() {
    // Off the pixel grid, with samples past both ends (e ≠ 0), a limb that thins as it
    // stretches, at every pyramid level (the scene drawn 2^level times larger, so that it
    // is as smooth at that level as at level 0: the analytic gradient is a central
    // difference half a level pixel wide).
    for lv in 0..LEVELS {
        let k = (1 << lv) as f32;
        let (p, c) = (Point::new(20.3, 30.4) * k, Point::new(50.2, 30.1) * k);
        let seed = smooth_bar_scaled(p, c, k);
        let frame = smooth_bar_scaled(Point::new(21.0, 30.5) * k, Point::new(51.0, 33.0) * k, k);
        let (sp, fp) = (Pyramid::new(&seed, LEVELS), Pyramid::new(&frame, LEVELS));
        let mut s = bone(&sp, p, c, 4.0 * k);
        s.width_exponent = 0.5;
        let (p0, c0) = (
            p + Vector::new(0.3, -0.2) * k,
            c + Vector::new(1.5, 0.7) * k,
        );
        let img = view(&fp, lv);
        let ne = s.normal(&img, p0, c0, 1.0, 1.0);
        let cost = |q: [f32; 4]| {
            let (a, b) = (Point::new(q[0], q[1]), Point::new(q[2], q[3]));
            s.normal(&img, a, b, 1.0, 1.0).cost
        };
        let q0 = [p0.x, p0.y, c0.x, c0.y];
        for i in 0..4 {
            let h = 0.05 * k;
            let (mut a, mut b) = (q0, q0);
            a[i] += h;
            b[i] -= h;
            let fd = (cost(a) - cost(b)) / (2.0 * h as f64);
            assert!(
                (fd - ne.g[i]).abs() < 0.2 * fd.abs().max(1e-3),
                "level {lv}, coordinate {i}: finite difference {fd}, analytic {}",
                ne.g[i]
            );
        }
    }
}

#[test]
fn gauss_newton_steps_towards_a_turned_and_stretched_bone() {
    // Seed: horizontal, 30 px. Frame: turned and stretched.
    let (p, c) = (Point::new(20.0, 30.0), Point::new(50.0, 30.0));
    let (p1, c1) = (Point::new(21.0, 30.5), Point::new(52.0, 33.0));
    let (seed, frame) = (smooth_bar(p, c), smooth_bar(p1, c1));
    let (sp, fp) = (Pyramid::new(&seed, LEVELS), Pyramid::new(&frame, LEVELS));
    let s = bone(&sp, p, c, 0.0);
    let (mut pp, mut cc) = (p, c);
    for k in 0..30 {
        let ne = s.normal(&view(&fp, 2 - k / 10), pp, cc, 100.0, 1.0);
        let h = nalgebra::Matrix4::from_fn(|i, j| ne.h[i][j] + if i == j { 1e-3 } else { 0.0 });
        let g = nalgebra::Vector4::from_fn(|i, _| ne.g[i]);
        let d = h.cholesky().unwrap().solve(&(-g));
        let clamp = |v: f64| v.clamp(-2.0, 2.0) as f32;
        pp += Vector::new(clamp(d[0]), clamp(d[1]));
        cc += Vector::new(clamp(d[2]), clamp(d[3]));
    }
    assert!((pp - p1).norm() < 0.3, "{pp:?} vs {p1:?}");
    assert!((cc - c1).norm() < 0.3, "{cc:?} vs {c1:?}");
}

#[test]
fn a_pixel_moving_with_another_bone_loses_its_weight() {
    // Seed: bar A horizontal; strip B claims A's pixels too. Frame: A stays, B's bone moved
    // away. B's samples fit where A's bone carries them, so they fade.
    let (p, c) = (Point::new(20.3, 30.4), Point::new(50.2, 30.1));
    let img = smooth_bar(p, c);
    let pyr = Pyramid::new(&img, LEVELS);
    let a = bone(&pyr, p, c, 0.0);
    let mut b = bone(&pyr, p, c, 0.0);
    b.link(1, &[a.extent, b.extent]);
    let moved = (p + Vector::new(0.0, 15.0), c + Vector::new(0.0, 15.0));
    let others = [Some(a.placement(p, c)), None];
    let before = b.weight_sum();
    let views: Vec<View> = (0..LEVELS).map(|k| view(&pyr, k)).collect();
    let fit = Fit::default();
    for _ in 0..10 {
        b.learn(&views, moved, &others, 0.2, 0.5, (5.0, 40.0), &fit);
    }
    assert!(
        b.weight_sum() < 0.1 * before,
        "{} of {before}",
        b.weight_sum()
    );
    // A sample that fits nowhere (hidden) keeps its weight.
    let mut c2 = bone(&pyr, p, c, 0.0);
    c2.link(1, &[a.extent, c2.extent]);
    for _ in 0..10 {
        c2.learn(&views, moved, &[None, None], 0.2, 0.5, (5.0, 40.0), &fit);
    }
    assert_eq!(c2.weight_sum(), before);
}

#[test]
fn learns_the_lengths_a_bone_is_seen_at_only_where_it_fits() {
    // Seed: 30 px. Frames: the bar squashed to 24 px and stretched to 36 px.
    let (p, c) = (Point::new(20.0, 30.0), Point::new(50.0, 30.0));
    let seed_img = smooth_bar(p, c);
    let seed = Pyramid::new(&seed_img, LEVELS);
    let mut s = bone(&seed, p, c, 0.0);
    assert_eq!(s.seen_lengths(), (30.0, 30.0));
    for end in [44.0, 56.0] {
        let c1 = Point::new(end, 30.0);
        let img = smooth_bar(p, c1);
        let pyr = Pyramid::new(&img, LEVELS);
        let views: Vec<View> = (0..LEVELS).map(|k| view(&pyr, k)).collect();
        let fit = s.fit(&views[0], p, c1);
        s.learn(&views, (p, c1), &[None], 0.1, 0.5, (5.0, 40.0), &fit);
    }
    let (lo, hi) = s.seen_lengths();
    assert!(
        (lo - 24.0).abs() < 1e-3 && (hi - 36.0).abs() < 1e-3,
        "{lo} {hi}"
    );
    // Laid where it does not fit (moved off the bar), a length says nothing.
    let (p2, c2) = (p + Vector::new(0.0, 20.0), Point::new(70.0, 50.0));
    let views: Vec<View> = (0..LEVELS).map(|k| view(&seed, k)).collect();
    let fit = s.fit(&views[0], p2, c2);
    s.learn(&views, (p2, c2), &[None], 0.1, 0.5, (5.0, 40.0), &fit);
    assert_eq!(s.seen_lengths(), (lo, hi));
}

/// A deterministic pseudo-random stream (SplitMix64): the tests need no `rand`.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * ((self.next() >> 40) as f32 / (1u64 << 24) as f32)
    }

    fn coin(&mut self) -> bool {
        self.next() & 1 == 1
    }
}

/// A textured `w × h` frame: smooth waves of random phase and frequency plus pixel noise.
fn random_frame(rng: &mut Rng, w: u32, h: u32) -> RgbImage {
    let waves: Vec<[f32; 4]> = (0..9)
        .map(|_| {
            [
                rng.range(0.02, 0.4),
                rng.range(0.02, 0.4),
                rng.range(0.0, 6.3),
                rng.range(20.0, 70.0),
            ]
        })
        .collect();
    let mut img = RgbImage::new(w, h);
    for (x, y, px) in img.enumerate_pixels_mut() {
        for ch in 0..3 {
            let [fx, fy, ph, amp] = waves[3 * ch + (x as usize + y as usize) % 3];
            let v = 128.0 + amp * (fx * x as f32 + fy * y as f32 + ph).sin() + rng.range(-8.0, 8.0);
            px[ch] = v.clamp(0.0, 255.0) as u8;
        }
    }
    img
}

/// `frame` with a random half of its pixels replaced (the rest within a few levels): a plate
/// that some samples match and some do not.
fn random_plate(rng: &mut Rng, frame: &RgbImage) -> RgbImage {
    let mut plate = frame.clone();
    for px in plate.pixels_mut() {
        let far = rng.coin();
        for ch in 0..3 {
            px[ch] = if far {
                (rng.next() & 255) as u8
            } else {
                (px[ch] as f32 + rng.range(-4.0, 4.0)).clamp(0.0, 255.0) as u8
            };
        }
    }
    plate
}

/// Every AVX2 build of a strip cost (`#[target_feature(enable = "avx2")]`: the coarse cost with
/// its early stop, the Gauss–Newton normal equations) gives the bits of the portable build, over
/// random strips (bones and patches, thinning with length or not, random sample weights, trusted
/// plate or not), images (odd sizes, every pyramid level), plates (none, at the frame's level:
/// the fast path, at another level: the general one) and poses (mirrored or not, partly or
/// wholly outside the frame, degenerate). The early stop is compared call by call: the lower
/// bounds it was asked about and whether it stopped.
#[test]
fn avx2_builds_give_the_portable_bits() {
    #[cfg(target_arch = "x86_64")]
    {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("note: this CPU has no AVX2; the AVX2 builds are not compared");
            return;
        }
        let mut rng = Rng(0x5EED_0030);
        let (mut calls, mut stopped, mut outside) = (0usize, 0usize, 0usize);
        for round in 0..24 {
            let (w, h) = (61 + 2 * (round % 5) as u32, 47 + (round % 3) as u32);
            let seed = random_frame(&mut rng, w, h);
            let frame = random_frame(&mut rng, w, h);
            let plate_img = random_plate(&mut rng, &frame);
            let (sp, fp, pp) = (
                Pyramid::new(&seed, LEVELS),
                Pyramid::new(&frame, LEVELS),
                Pyramid::new(&plate_img, LEVELS),
            );
            let (wf, hf) = (w as f32, h as f32);
            for _ in 0..6 {
                let shape = if rng.range(0.0, 1.0) < 0.8 {
                    Shape::Bone
                } else {
                    Shape::Patch
                };
                let a = Point::new(rng.range(12.0, wf - 12.0), rng.range(12.0, hf - 12.0));
                let b = Point::new(rng.range(12.0, wf - 12.0), rng.range(12.0, hf - 12.0));
                let ext = Extent {
                    a,
                    b: if shape == Shape::Bone { b } else { a },
                    ext_a: rng.range(0.0, 6.0) + if shape == Shape::Patch { 4.0 } else { 0.0 },
                    ext_b: rng.range(0.0, 6.0),
                    half_width: rng.range(2.0, 7.0),
                };
                let spec = StripSpec {
                    max_samples: 60 + (rng.next() % 300) as usize,
                    coarse_samples: 8 + (rng.next() % 60) as usize,
                    sigma: rng.range(5.0, 30.0),
                    width_exponent: if rng.coin() { 0.0 } else { rng.range(0.2, 1.0) },
                };
                let child = if shape == Shape::Bone { 1 } else { 0 };
                let share = |x: f32, y: f32| ((x * 0.37 + y * 0.61).sin() + 1.0) * 1.5;
                let Some(mut s) = Strip::sample(&sp, shape, (0, child), ext, &spec, &[], &share)
                else {
                    continue;
                };
                // Sample weights of every kind: none, partial, full.
                for r in s.rel.iter_mut() {
                    *r = rng.range(0.0, 1.2).min(1.0);
                }
                s.trust_plate = rng.range(0.0, 1.0) < 0.75;
                s.mirrored = rng.coin();
                s.refresh_coarse();
                for lv in 0..LEVELS {
                    for plate_kind in 0..3 {
                        let plate = match plate_kind {
                            0 => None,
                            1 => Some(pp.level(lv)),
                            _ => Some(pp.level((lv + 1) % LEVELS)),
                        };
                        let v = View {
                            img: fp.level(lv),
                            plate,
                            gain: rng.range(0.8, 1.25),
                            bg_inv: 1.0 / (3.0 * rng.range(2.0, 12.0).powi(2)),
                        };
                        for _ in 0..4 {
                            // Poses reaching up to 40 px outside the frame; now and then one
                            // wholly outside, or with both joints at one point.
                            let mut pt = || {
                                Point::new(rng.range(-40.0, wf + 40.0), rng.range(-40.0, hf + 40.0))
                            };
                            let (p, mut c) = (pt(), pt());
                            match rng.next() % 8 {
                                0 => c = p,
                                1 => c = Point::new(wf + 500.0, -300.0),
                                _ => {}
                            }
                            outside += s
                                .probe(&v, p, c)
                                .iter()
                                .filter(|q| q.2.is_infinite())
                                .count()
                                .min(1);
                            for mirrored in [false, true] {
                                let limit = match rng.next() % 3 {
                                    0 => f32::INFINITY,
                                    _ => rng.range(0.0, 1.0),
                                };
                                let run = |avx2: bool| {
                                    let asked = std::cell::RefCell::new(Vec::new());
                                    let stop = |m: f32| {
                                        asked.borrow_mut().push(m.to_bits());
                                        m >= limit
                                    };
                                    // SAFETY: the CPU has AVX2 (checked above).
                                    let cost = if avx2 {
                                        unsafe {
                                            s.coarse_cost_until_avx2(&v, p, c, mirrored, stop)
                                        }
                                    } else {
                                        s.coarse_cost_until_any(&v, p, c, mirrored, stop)
                                    };
                                    (cost.map(f32::to_bits), asked.into_inner())
                                };
                                let (any, avx2) = (run(false), run(true));
                                assert_eq!(
                                    any, avx2,
                                    "coarse cost, round {round}, level {lv}, plate {plate_kind}, \
                                     pose {p:?} {c:?}, mirrored {mirrored}, limit {limit}"
                                );
                                calls += 1;
                                stopped += any.0.is_none() as usize;
                            }
                            let weight = rng.range(0.1, 100.0);
                            let widen = [1.0, 2.0, 4.0][(rng.next() % 3) as usize];
                            let bits = |n: Normal| {
                                let mut out = vec![n.cost.to_bits()];
                                out.extend(n.g.iter().map(|g| g.to_bits()));
                                out.extend(n.h.iter().flatten().map(|h| h.to_bits()));
                                out
                            };
                            let any = bits(s.normal_any(&v, p, c, weight, widen));
                            // SAFETY: the CPU has AVX2 (checked above).
                            let avx2 = bits(unsafe { s.normal_avx2(&v, p, c, weight, widen) });
                            assert_eq!(
                                any, avx2,
                                "normal equations, round {round}, level {lv}, plate {plate_kind}, \
                                 pose {p:?} {c:?}, weight {weight}, widen {widen}"
                            );
                        }
                    }
                }
            }
        }
        eprintln!("{calls} coarse costs ({stopped} stopped early, {outside} poses partly outside)");
        // The cases the comparison is for did occur.
        assert!(calls > 1000, "{calls} coarse costs compared");
        assert!(
            stopped > calls / 20 && stopped < calls * 19 / 20,
            "{stopped} of {calls} stopped early"
        );
        assert!(outside > calls / 10, "{outside} poses partly outside");
    }
}
