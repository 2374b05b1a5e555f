use super::*;

/// A smooth textured frame, shifted by `(sx, sy)` px.
fn frame(sx: f32, sy: f32) -> RgbImage {
    RgbImage::from_fn(160, 120, |x, y| {
        let (u, v) = (x as f32 - sx, y as f32 - sy);
        let g = 128.0 + 60.0 * (u * 0.21).sin() * (v * 0.17).cos() + 40.0 * ((u + v) * 0.09).sin();
        image::Rgb([g as u8, g as u8, g as u8])
    })
}

#[test]
fn follows_a_shift_to_a_tenth_of_a_pixel() {
    let a = GreyPyramid::new(&frame(0.0, 0.0), 4);
    let b = GreyPyramid::new(&frame(7.3, -4.6), 4);
    let prm = FlowParams::default();
    let (q, fb) = track_checked(&a, &b, Point::new(80.0, 60.0), &prm).expect("tracked");
    assert!(
        (q.x - 87.3).abs() < 0.1 && (q.y - 55.4).abs() < 0.1,
        "{q:?}"
    );
    assert!(fb < 0.1, "forward–backward error {fb}");
}

#[test]
fn refuses_a_flat_window() {
    let flat = RgbImage::from_pixel(160, 120, image::Rgb([90, 90, 90]));
    let a = GreyPyramid::new(&flat, 4);
    assert!(track_point(&a, &a, Point::new(80.0, 60.0), &FlowParams::default()).is_none());
}

#[test]
fn luma_is_the_same_on_every_cpu() {
    // 37 pixels (four blocks of eight and a remainder) of varied bytes.
    let rgb: Vec<u8> = (0..111u32).map(|i| (i * 97 % 256) as u8).collect();
    let mut fast = vec![0.0f32; 37];
    let mut plain = vec![1.0f32; 37];
    luma_into(&rgb, &mut fast);
    build::luma_any(&rgb, &mut plain);
    assert_eq!(fast, plain);
    let want: Vec<f32> = rgb
        .chunks_exact(3)
        .map(|p| 0.299 * p[0] as f32 + 0.587 * p[1] as f32 + 0.114 * p[2] as f32)
        .collect();
    assert_eq!(fast, want);
}

#[test]
fn a_rebuilt_pyramid_is_a_new_one() {
    let (big, small) = (
        frame(1.0, 2.0),
        RgbImage::from_fn(67, 45, |x, y| image::Rgb([x as u8, y as u8, 7])),
    );
    let mut p = GreyPyramid::new(&big, 4);
    p.rebuild(&small, 4);
    let want = GreyPyramid::new(&small, 4);
    assert_eq!(p.levels.len(), want.levels.len());
    for (a, b) in p.levels.iter().zip(&want.levels) {
        assert_eq!((a.width, a.height, &a.data), (b.width, b.height, &b.data));
    }
}

/// [`track_point`] gives what a bilinear sample at a time gives (the implementation before
/// the window's axes and rows were shared), to the bit: inside, near the borders (where coarse
/// levels are skipped or the window leaves the frame), on flat and odd-sized windows.
#[test]
fn the_same_points_as_one_sample_at_a_time() {
    let a = GreyPyramid::new(&frame(0.0, 0.0), 5);
    let b = GreyPyramid::new(&frame(3.7, -2.2), 5);
    let mut seen = (0, 0);
    for half in [4usize, 9, 15] {
        let prm = FlowParams {
            half,
            ..FlowParams::default()
        };
        for y in (0..120).step_by(7) {
            for x in (0..160).step_by(9) {
                let p = Point::new(x as f32 + 0.37, y as f32 - 0.21);
                let got = track_point(&a, &b, p, &prm);
                let want = reference(&a, &b, p, &prm);
                assert_eq!(
                    got.map(|q| (q.x.to_bits(), q.y.to_bits())),
                    want.map(|q| (q.x.to_bits(), q.y.to_bits())),
                    "{p:?}, half {half}"
                );
                if got.is_some() {
                    seen.0 += 1;
                } else {
                    seen.1 += 1;
                }
            }
        }
    }
    assert!(seen.0 > 100 && seen.1 > 10, "{seen:?}");
}

/// Bilinear sample at `(x, y)` (level px); `None` outside the level (one pixel margin).
#[inline]
fn sample(level: &GreyLevel, x: f32, y: f32) -> Option<f32> {
    if !(x >= 0.0 && y >= 0.0) {
        return None;
    }
    let (x0, y0) = (x as usize, y as usize);
    if x0 + 1 >= level.width || y0 + 1 >= level.height {
        return None;
    }
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let i = y0 * level.width + x0;
    let d = &level.data;
    let top = d[i] + fx * (d[i + 1] - d[i]);
    let bot = d[i + level.width] + fx * (d[i + level.width + 1] - d[i + level.width]);
    Some(top + fy * (bot - top))
}

fn reference(a: &GreyPyramid, b: &GreyPyramid, p: Point, prm: &FlowParams) -> Option<Point> {
    let levels = a.levels.len().min(b.levels.len());
    let half = prm.half as i32;
    let n = (2 * half + 1) as usize;
    let mut tmpl = vec![0.0f32; n * n];
    let mut gx = vec![0.0f32; n * n];
    let mut gy = vec![0.0f32; n * n];
    // Displacement guess, in the current level's px.
    let (mut dx, mut dy) = (0.0f32, 0.0f32);
    for lvl in (0..levels).rev() {
        let la = &a.levels[lvl];
        let lb = &b.levels[lvl];
        let s = 1.0 / (1u32 << lvl) as f32;
        let (px, py) = (p.x * s, p.y * s);
        // Template, its gradients and their matrix on frame a.
        let (mut gxx, mut gxy, mut gyy) = (0.0f32, 0.0f32, 0.0f32);
        let mut inside = true;
        'win: for j in -half..=half {
            for i in -half..=half {
                let (x, y) = (px + i as f32, py + j as f32);
                let (Some(c), Some(l), Some(r), Some(u), Some(d)) = (
                    sample(la, x, y),
                    sample(la, x - 1.0, y),
                    sample(la, x + 1.0, y),
                    sample(la, x, y - 1.0),
                    sample(la, x, y + 1.0),
                ) else {
                    inside = false;
                    break 'win;
                };
                let k = ((j + half) as usize) * n + (i + half) as usize;
                tmpl[k] = c;
                gx[k] = 0.5 * (r - l);
                gy[k] = 0.5 * (d - u);
                gxx += gx[k] * gx[k];
                gxy += gx[k] * gy[k];
                gyy += gy[k] * gy[k];
            }
        }
        if !inside {
            // The window leaves a coarse level near the border: go on at the next finer one.
            if lvl == 0 {
                return None;
            }
            dx *= 2.0;
            dy *= 2.0;
            continue;
        }
        let area = (n * n) as f32;
        let tr = gxx + gyy;
        let det = gxx * gyy - gxy * gxy;
        let min_eig = 0.5 * (tr - ((gxx - gyy).powi(2) + 4.0 * gxy * gxy).sqrt());
        if min_eig / area < prm.min_eigen || det <= f32::EPSILON {
            return None;
        }
        for _ in 0..prm.iterations {
            let (mut bx, mut by) = (0.0f32, 0.0f32);
            for j in -half..=half {
                for i in -half..=half {
                    let k = ((j + half) as usize) * n + (i + half) as usize;
                    let v = sample(lb, px + dx + i as f32, py + dy + j as f32)?;
                    let diff = tmpl[k] - v;
                    bx += diff * gx[k];
                    by += diff * gy[k];
                }
            }
            let sx = (gyy * bx - gxy * by) / det;
            let sy = (gxx * by - gxy * bx) / det;
            dx += sx;
            dy += sy;
            if sx * sx + sy * sy < prm.epsilon * prm.epsilon {
                break;
            }
        }
        if lvl > 0 {
            dx *= 2.0;
            dy *= 2.0;
        }
    }
    let q = Point::new(p.x + dx, p.y + dy);
    (q.x.is_finite() && q.y.is_finite()).then_some(q)
}
