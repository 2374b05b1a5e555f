//! Development diagnostics: renders a synth clip in memory, tracks it and prints per-joint
//! errors at each tracker stage for the frames where something goes wrong.
//!
//!     cargo run --release --example diag -- SCENARIO [--frames N] [--from F] [--to F] [--mp4]
#[path = "common/probe.rs"]
mod probe;
#[path = "common/size.rs"]
mod size;

use mocap2d::background::Background;
use mocap2d::synth::{render, Scenario, SynthOptions};
use mocap2d::track::Tracker;
use std::str::FromStr;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let sc = Scenario::from_str(&args[0]).map_err(anyhow::Error::msg)?;
    let get = |k: &str| {
        args.iter()
            .position(|a| a == k)
            .map(|i| args[i + 1].clone())
    };
    let frames = get("--frames").map(|v| v.parse().unwrap());
    let from: usize = get("--from").map_or(0, |v| v.parse().unwrap());
    let to: usize = get("--to").map_or(usize::MAX, |v| v.parse().unwrap());
    let thr: f32 = get("--thr").map_or(3.0, |v| v.parse().unwrap());
    let seed: u64 = get("--seed").map_or(1, |v| v.parse().unwrap());
    let (width, height) = get("--size").map_or((640, 360), |v| size::parse_size(&v).unwrap());
    let clip = render(&SynthOptions {
        scenario: sc,
        width,
        height,
        seed,
        frames,
    });
    let frames_img: Vec<_> = if args.iter().any(|a| a == "--mp4") {
        let dir = tempfile::tempdir()?;
        mocap2d::synth::write_clip(&clip, dir.path())?;
        mocap2d::decode::read_all(&dir.path().join("clip.mp4"), None)?
    } else {
        clip.frames.clone()
    };
    let seeds = mocap2d::seed::parse_seeds(&clip.seeds_toml(), std::path::Path::new("seeds"))?;
    let bg = Background::fit(
        &frames_img
            .iter()
            .step_by((frames_img.len() / 25).max(1))
            .cloned()
            .collect::<Vec<_>>(),
    )?;
    let params = mocap2d::app::read_params(
        std::env::var("PARAMS")
            .ok()
            .as_deref()
            .map(std::path::Path::new),
    )?;
    let mut t = Tracker::new(params, &seeds, &frames_img[0], Some(bg));
    t.enable_trace();
    if args.iter().any(|a| a == "--strips") {
        for l in t.strip_summaries() {
            println!("{l}");
        }
    }
    let names = &clip.joint_names;
    let mut tot = 0;
    let mut good = 0;
    let mut per = vec![(0usize, 0usize); names.len()];
    let mut miss_vis = [0usize; 3];
    let (mut truth_better, mut est_better) = (0usize, 0usize);
    let mut filler = t.gap_filler();
    let mut filled: Vec<(u64, Vec<mocap2d::track::JointEstimate>)> = filler.push(0, t.current());
    let mut out = String::from("frame,joint,x,y,angle,score,status\n");
    for j in 0..names.len() {
        let (x, y) = clip.gt[0][j];
        out += &format!("0,{},{x},{y},0,1,seed\n", names[j]);
    }
    for f in 1..frames_img.len() {
        let est = t.step(&frames_img[f]);
        if args.iter().any(|a| a == "--strips") && (f == 10 || f == 60) {
            println!("frame {f}");
            for l in t.strip_summaries() {
                println!("{l}");
            }
        }
        filled.extend(filler.push(f as u64, est.clone()));
        let tr = t.trace().unwrap();
        if let Some(pos) = args.iter().position(|a| a == "--probe") {
            // --probe FRAME JOINT: fits of the joint's bones at the truth and at the estimate
            let (pf, pj): (usize, &str) = (args[pos + 1].parse().unwrap(), &args[pos + 2]);
            if pf == f {
                let j = names.iter().position(|n| n == pj).unwrap();
                let gp = |k: usize| mocap2d::geom::Point::new(clip.gt[f][k].0, clip.gt[f][k].1);
                let par = clip.parents[j].unwrap();
                let fr = &frames_img[f];
                println!(
                    "probe {pj} at frame {f}: truth {:?}",
                    t.fit_bone(fr, j, gp(par), gp(j))
                );
                // Picture: the frame around the bone, 4x, samples at the truth (inliers green,
                // outliers red, weightless grey).
                let pr = t.probe_bone(fr, j, gp(par), gp(j));
                probe::save_probe(fr, gp(par), gp(j), &pr, "/tmp/probe.png");
                println!(
                    "   estimate {:?}",
                    t.fit_bone(fr, j, est[par].pos, est[j].pos)
                );
                println!(
                    "   truth parent, est child {:?}",
                    t.fit_bone(fr, j, gp(par), est[j].pos)
                );
                for c in 0..names.len() {
                    if clip.parents[c] == Some(j) {
                        println!(
                            "   child {} truth {:?}",
                            names[c],
                            t.fit_bone(fr, c, gp(j), gp(c))
                        );
                        println!(
                            "   child {} est {:?}",
                            names[c],
                            t.fit_bone(fr, c, est[j].pos, est[c].pos)
                        );
                    }
                }
            }
        }
        for j in 0..names.len() {
            out += &format!(
                "{f},{},{},{},0,{},{}\n",
                names[j],
                est[j].pos.x,
                est[j].pos.y,
                est[j].score,
                est[j].status.as_str()
            );
        }
        let mut lines = Vec::new();
        for j in 0..names.len() {
            let g = clip.gt[f][j];
            let e = |p: mocap2d::geom::Point| (p.x - g.0).hypot(p.y - g.1);
            tot += 1;
            per[j].0 += 1;
            if e(est[j].pos) <= 5.0 {
                good += 1;
                per[j].1 += 1;
            } else {
                let v = clip.visibility[f][j];
                miss_vis[if v < 0.3 {
                    0
                } else if v < 0.7 {
                    1
                } else {
                    2
                }] += 1;
                if v >= 0.7 {
                    if let Some(par) = clip.parents[j] {
                        let gp =
                            |k: usize| mocap2d::geom::Point::new(clip.gt[f][k].0, clip.gt[f][k].1);
                        let ft = t.fit_bone(&frames_img[f], j, gp(par), gp(j));
                        let fe = t.fit_bone(&frames_img[f], j, est[par].pos, est[j].pos);
                        if let (Some(ft), Some(fe)) = (ft, fe) {
                            if ft.cost < fe.cost {
                                truth_better += 1;
                            } else {
                                est_better += 1;
                            }
                        }
                    }
                }
            }
            if e(est[j].pos) > thr || (f >= from && f <= to && e(tr.refined[j]) > thr) {
                lines.push(format!(
                    "  {:8} vis={:.2} pred={:5.1} search={:5.1} refine={:5.1} final={:5.1} ev={:.2} {}{}",
                    names[j], clip.visibility[f][j], e(tr.predicted[j]), e(tr.searched[j]), e(tr.refined[j]), e(est[j].pos),
                    tr.evidence[j], est[j].status.as_str(), if tr.reacquired[j] { " REACQ" } else { "" }
                ));
            }
        }
        if f >= from && f <= to && !lines.is_empty() {
            println!("frame {f}");
            for l in lines {
                println!("{l}");
            }
        }
    }
    std::fs::write(format!("/tmp/diag_{}.csv", sc.name()), out)?;
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
    filled.extend(filler.finish());
    let (mut fg, mut ft) = (0, 0);
    let mut spans = vec![(0usize, 0usize); filled.len() / 50 + 1];
    for (f, est) in &filled {
        for j in 0..names.len() {
            let g = clip.gt[*f as usize][j];
            ft += 1;
            spans[*f as usize / 50].1 += 1;
            if (est[j].pos.x - g.0).hypot(est[j].pos.y - g.1) <= 5.0 {
                fg += 1;
                spans[*f as usize / 50].0 += 1;
            }
        }
    }
    if filled.len() > 150 {
        let s: Vec<String> = spans
            .iter()
            .enumerate()
            .map(|(i, (g, t))| format!("{}:{:.0}", i * 50, 100.0 * *g as f32 / (*t).max(1) as f32))
            .collect();
        println!("PCK@5 per 50 frames: {}", s.join(" "));
    }
    println!("visible misses: truth fits better {truth_better}, estimate fits better {est_better}");
    println!("misses by visibility (hidden / partly / visible): {miss_vis:?}; after gap fill PCK@5 {:.1}%", 100.0 * fg as f32 / ft as f32);
    let worst: Vec<String> = (0..names.len())
        .filter(|&j| per[j].1 < per[j].0)
        .map(|j| {
            format!(
                "{}:{:.0}",
                names[j],
                100.0 * per[j].1 as f32 / per[j].0 as f32
            )
        })
        .collect();
    println!(
        "PCK@5 (before gap fill) {:.1}%  [{}]",
        100.0 * good as f32 / tot as f32,
        worst.join(" ")
    );
    Ok(())
}
