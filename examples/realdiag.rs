//! Development diagnostics on a real clip with labels: tracks it (streaming, background as
//! `track` builds it), prints the strips, per-100-frame PCK@5, per-joint PCK@5, stage timings, and
//! the joints more than `--thr` px off between `--from` and `--to`, each with its error at every
//! stage of the frame's step (prediction, search, refinement, final) and its evidence.
//!
//!     cargo run --release --example realdiag -- CLIP SEEDS GT [--thr PX] [--from F] [--to F]
//!         [--fits] [--probe FRAME JOINT [--at-estimate]] [--gains]
//!
//! `--gains` prints every frame's gain over the plate as the plate shows it and as the
//! templates were judged at (`track::exposure`).
//! `--fits` prints, for those joints, the cost of each bone to their children laid on the labels
//! and on the estimates (which pose the strips' appearance prefers); `--probe` saves
//! /tmp/probe.png, the bone's samples at the labels (or the estimate) on that frame: green fit,
//! red do not, grey carry no weight. The clean plate goes to /tmp/plate.png.
#[path = "common/probe.rs"]
mod probe;

use mocap2d::background::BackgroundChoice;
use mocap2d::decode;
use mocap2d::geom::Point;
use mocap2d::track::Tracker;
use std::collections::HashMap;
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |k: &str| {
        args.iter()
            .position(|a| a == k)
            .map(|i| args[i + 1].clone())
    };
    let (clip, seeds_path, gt_path) = (
        PathBuf::from(&args[0]),
        PathBuf::from(&args[1]),
        PathBuf::from(&args[2]),
    );
    let thr: f32 = get("--thr").map_or(1e9, |v| v.parse().unwrap());
    let from: u64 = get("--from").map_or(0, |v| v.parse().unwrap());
    let to: u64 = get("--to").map_or(u64::MAX, |v| v.parse().unwrap());
    let params = mocap2d::app::read_params(
        std::env::var("PARAMS")
            .ok()
            .as_deref()
            .map(std::path::Path::new),
    )?;
    let (seeds, _) = mocap2d::seed::read_seeds(&seeds_path)?;
    let mut source = decode::open(&clip, None)?;
    let (w, h) = (source.info().width, source.info().height);
    let bg = BackgroundChoice::Median
        .build(&clip, None, w, h, Some(&seeds))?
        .model;
    if let Some(b) = &bg {
        b.plate.save("/tmp/plate.png")?;
        eprintln!("clean plate saved to /tmp/plate.png");
    }
    let gt = mocap2d::eval::read_gt(&gt_path)?;
    let truth: HashMap<(u64, &str), (f32, f32)> = gt
        .iter()
        .map(|g| ((g.frame, g.joint.as_str()), (g.x, g.y)))
        .collect();
    let names: Vec<String> = seeds.joints.iter().map(|j| j.name.clone()).collect();
    let mut tracker: Option<Tracker> = None;
    let (mut spans, mut per) = (
        HashMap::<u64, (u32, u32)>::new(),
        vec![(0u32, 0u32); names.len()],
    );
    let mut idx = 0u64;
    let mut bg = bg;
    while let Some(frame) = source.next_frame()? {
        let est = match tracker.as_mut() {
            None => {
                let mut t = Tracker::new(params.clone(), &seeds, &frame, bg.take());
                t.enable_trace();
                for l in t.strip_summaries() {
                    println!("{l}");
                }
                tracker = Some(t);
                tracker.as_ref().unwrap().current()
            }
            Some(t) => t.step(&frame),
        };
        if let Some(pos) = args.iter().position(|a| a == "--probe") {
            // --probe FRAME JOINT: picture of the joint's bone samples at the truth (/tmp/probe.png)
            let (pf, pj): (u64, &str) = (args[pos + 1].parse().unwrap(), &args[pos + 2]);
            if pf == idx {
                let t = tracker.as_ref().unwrap();
                let j = names.iter().position(|n| n == pj).unwrap();
                let par = seeds.skeleton.parents[j].unwrap();
                let g = |k: usize| {
                    let (x, y) = truth[&(idx, names[k].as_str())];
                    mocap2d::geom::Point::new(x, y)
                };
                let (gp, gc) = if args.iter().any(|a| a == "--at-estimate") {
                    (est[par].pos, est[j].pos)
                } else {
                    (g(par), g(j))
                };
                println!("probe {pj} at {idx}: {:?}", t.fit_bone(&frame, j, gp, gc));
                let pr = t.probe_bone(&frame, j, gp, gc);
                probe::save_probe(&frame, gp, gc, &pr, "/tmp/probe.png");
            }
        }
        if let (true, Some(tr)) = (
            args.iter().any(|a| a == "--gains"),
            tracker.as_ref().and_then(|t| t.trace()),
        ) {
            if idx > 0 {
                println!(
                    "gain {idx} plate {:.4} judged {:.4}",
                    tr.plate_gain, tr.gain
                );
            }
        }
        let mut lines = Vec::new();
        for (j, n) in names.iter().enumerate() {
            let Some(&(x, y)) = truth.get(&(idx, n.as_str())) else {
                continue;
            };
            let e = (est[j].pos.x - x).hypot(est[j].pos.y - y);
            let s = spans.entry(idx / 100).or_default();
            s.1 += 1;
            per[j].1 += 1;
            if e <= 5.0 {
                s.0 += 1;
                per[j].0 += 1;
            }
            if e > thr && idx >= from && idx <= to {
                let t = tracker.as_ref().expect("built on the first frame");
                let off = |p: Point| (p.x - x).hypot(p.y - y);
                let stages = match (idx, t.trace()) {
                    (1.., Some(tr)) => format!(
                        " pred={:5.1} search={:5.1} refine={:5.1} evidence={:.2}",
                        off(tr.predicted[j]),
                        off(tr.searched[j]),
                        off(tr.refined[j]),
                        tr.evidence[j]
                    ),
                    _ => String::new(),
                };
                lines.push(format!(
                    "  {n:18} err={e:6.1} score={:.2} {}{stages}",
                    est[j].score,
                    est[j].status.as_str()
                ));
                if args.iter().any(|a| a == "--fits") {
                    for (c, jc) in seeds.joints.iter().enumerate() {
                        let label = |k: usize| {
                            let &(lx, ly) = truth.get(&(idx, names[k].as_str()))?;
                            Some(Point::new(lx, ly))
                        };
                        if jc.parent.as_deref() != Some(n.as_str()) {
                            continue;
                        }
                        let (Some(lj), Some(lc)) = (label(j), label(c)) else {
                            continue;
                        };
                        let fits = (
                            t.fit_bone(&frame, c, lj, lc),
                            t.fit_bone(&frame, c, est[j].pos, est[c].pos),
                        );
                        if let (Some(a), Some(b)) = fits {
                            lines.push(format!(
                                "    -> {:16} cost on the labels {:.3} (inliers {:.2}), on the estimates {:.3} ({:.2})",
                                names[c], a.cost, a.inliers, b.cost, b.inliers
                            ));
                        }
                    }
                }
            }
        }
        if !lines.is_empty() {
            println!("frame {idx}\n{}", lines.join("\n"));
        }
        idx += 1;
    }
    let mut keys: Vec<_> = spans.keys().copied().collect();
    keys.sort();
    let s: Vec<String> = keys
        .iter()
        .map(|k| {
            let (g, t) = spans[k];
            format!("{}:{:.0}", k * 100, 100.0 * g as f32 / t.max(1) as f32)
        })
        .collect();
    println!("PCK@5 per 100 frames: {}", s.join(" "));
    let p: Vec<String> = names
        .iter()
        .zip(&per)
        .map(|(n, (g, t))| format!("{n}:{:.0}", 100.0 * *g as f32 / (*t).max(1) as f32))
        .collect();
    println!("PCK@5 per joint: {}", p.join(" "));
    if let Some(t) = &tracker {
        let tm = t.timings();
        let ms = |s: f64| 1000.0 * s / tm.frames.max(1) as f64;
        println!(
            "ms/frame: pyramid {:.2} search {:.2} refine {:.2} judge {:.2} reacquire {:.2} learn {:.2}",
            ms(tm.pyramid),
            ms(tm.search),
            ms(tm.refine),
            ms(tm.judge),
            ms(tm.reacquire),
            ms(tm.learn)
        );
    }
    Ok(())
}
