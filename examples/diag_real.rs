//! Development diagnostics on a real clip folder (clip.mp4, joints.toml, gt.csv): tracks it as
//! `track` would (the median plate with the seeds, default parameters, one tracker, no
//! segments) and prints, for the frames `FROM..=TO` and the joints named, each stage's error
//! against the labels (prediction, search, refinement, final) and the joint's evidence; then
//! the tracker's time a frame by stage. With `DIAG_FITS=1`, also the cost of each bone from a
//! watched joint to its children laid on the labels and on the estimates (which pose the
//! tracker's appearance prefers).
//!
//!     cargo run --release --example diag_real -- DIR FROM TO JOINT[,JOINT...]
use mocap2d::background::BackgroundChoice;
use mocap2d::decode;
use mocap2d::geom::Point;
use mocap2d::track::{TrackParams, Tracker};
use std::collections::HashMap;
use std::path::Path;

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(
        a.len() == 4,
        "usage: diag_real DIR FROM TO JOINT[,JOINT...]"
    );
    let dir = Path::new(&a[0]);
    let (from, to): (u64, u64) = (a[1].parse()?, a[2].parse()?);
    let watch: Vec<&str> = a[3].split(',').collect();
    let clip = dir.join("clip.mp4");
    let (seeds, _) = mocap2d::seed::read_seeds(&dir.join("joints.toml"))?;
    let mut gt: HashMap<(u64, String), Point> = HashMap::new();
    for l in std::fs::read_to_string(dir.join("gt.csv"))?.lines().skip(1) {
        let v: Vec<&str> = l.split(',').collect();
        gt.insert(
            (v[0].parse()?, v[1].to_string()),
            Point::new(v[2].parse()?, v[3].parse()?),
        );
    }
    let names: Vec<String> = seeds.joints.iter().map(|j| j.name.clone()).collect();
    let watched: Vec<usize> = watch
        .iter()
        .map(|w| {
            names
                .iter()
                .position(|n| n == w)
                .ok_or_else(|| anyhow::anyhow!("no joint {w}"))
        })
        .collect::<anyhow::Result<_>>()?;
    let mut src = decode::open(&clip, None)?;
    let info = src.info().clone();
    let (bg, _) =
        BackgroundChoice::Median.build(&clip, None, info.width, info.height, Some(&seeds))?;
    anyhow::ensure!(seeds.frame == 0, "seeds on frame 0 only");
    let first = src
        .next_frame()?
        .ok_or_else(|| anyhow::anyhow!("empty clip"))?;
    let mut t = Tracker::new(TrackParams::default(), &seeds, &first, bg);
    t.enable_trace();
    let mut f = 0u64;
    while let Some(img) = src.next_frame()? {
        f += 1;
        if f > to {
            break;
        }
        let est = t.step(&img);
        if f < from {
            continue;
        }
        let tr = t.trace().expect("trace enabled");
        let mut line = format!("{f}");
        for &j in &watched {
            let Some(g) = gt.get(&(f, names[j].clone())) else {
                continue;
            };
            let e = |p: Point| (p - g).norm();
            line += &format!(
                " | {} pred {:5.1} search {:5.1} refine {:5.1} final {:5.1} evidence {:.2} {}",
                names[j],
                e(tr.predicted[j]),
                e(tr.searched[j]),
                e(tr.refined[j]),
                e(est[j].pos),
                tr.evidence[j],
                est[j].status.as_str()
            );
        }
        println!("{line}");
        if std::env::var("DIAG_FITS").is_ok() {
            // The cost of every bone from a watched joint to its children, laid on the labels
            // and on the estimates.
            for &j in &watched {
                for (c, jc) in seeds.joints.iter().enumerate() {
                    if jc.parent.as_deref() != Some(names[j].as_str()) {
                        continue;
                    }
                    let (Some(gj), Some(gc)) = (
                        gt.get(&(f, names[j].clone())),
                        gt.get(&(f, names[c].clone())),
                    ) else {
                        continue;
                    };
                    let truth = t.fit_bone(&img, c, *gj, *gc);
                    let est_fit = t.fit_bone(&img, c, est[j].pos, est[c].pos);
                    if let (Some(a), Some(b)) = (truth, est_fit) {
                        println!(
                            "    {} -> {}: cost on labels {:.3} (inliers {:.2}), on estimates {:.3} ({:.2})",
                            names[j], names[c], a.cost, a.inliers, b.cost, b.inliers
                        );
                    }
                }
            }
        }
    }
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
    Ok(())
}
