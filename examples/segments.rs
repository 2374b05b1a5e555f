//! What segments cost and what the report finds, on the synthetic scenarios: each is rendered
//! (640×360 unless `--size`, seed 1, the scenario's length unless `--frames`), encoded, and tracked through `mocap2d::app::track` once per
//! segment length; per run it prints PCK@5, the median error, the segments the report flags and
//! the report's recall (share of joint-frames more than 10 px off that lie in flagged segments).
//! A segment length of 0 stands for one segment over the whole clip (continuous tracking).
//!
//! ```sh
//! cargo run --release --example segments -- walk occlude --len 0,30,60
//! cargo run --release --example segments -- long --len 0,150,300
//! cargo run --release --example segments -- walk squash --frames 450 --len 0,150
//! ```
#[path = "common/size.rs"]
mod size;

use mocap2d::app::{track, TrackOptions};
use mocap2d::progress::NoProgress;
use mocap2d::run::segments::Plan;
use mocap2d::run::tracks::read_tracks;
use mocap2d::synth::{render, write_clip, Scenario, SynthOptions};

fn main() -> anyhow::Result<()> {
    let mut scenarios = Vec::new();
    let mut lens = vec![0u64, 30, 60];
    let mut size = (640, 360);
    let mut frames = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--len" => {
                lens = args
                    .next()
                    .unwrap_or_default()
                    .split(',')
                    .map(|v| v.parse())
                    .collect::<Result<_, _>>()?
            }
            "--frames" => frames = Some(args.next().unwrap_or_default().parse()?),
            "--size" => {
                size = size::parse_size(&args.next().unwrap_or_default())
                    .map_err(anyhow::Error::msg)?
            }
            s => scenarios.push(s.parse::<Scenario>()?),
        }
    }
    if scenarios.is_empty() {
        scenarios = Scenario::ALL[..5].to_vec();
    }
    for sc in scenarios {
        let dir = tempfile::tempdir()?;
        let clip = render(&SynthOptions {
            scenario: sc,
            width: size.0,
            height: size.1,
            seed: 1,
            frames,
        });
        write_clip(&clip, dir.path())?;
        for &len in &lens {
            let len_used = if len == 0 { u64::MAX / 4 } else { len };
            let run = dir.path().join(format!("run{len}"));
            let opts = TrackOptions {
                out: Some(run.clone()),
                segment_len: len_used,
                ..TrackOptions::new(dir.path().join("clip.mp4"), dir.path().join("joints.toml"))
            };
            let t0 = std::time::Instant::now();
            let s = track(&opts, &NoProgress)?;
            let secs = t0.elapsed().as_secs_f64();
            let plan = Plan {
                seed_frame: 0,
                len: len_used,
            };
            let rows = read_tracks(&run.join("tracks.csv"))?;
            let nj = clip.gt[0].len();
            let mut errs = Vec::new();
            let (mut far, mut caught) = (0, 0);
            for (i, r) in rows.iter().enumerate() {
                let (x, y) = clip.gt[r.frame as usize][i % nj];
                let e = (r.x - x).hypot(r.y - y);
                errs.push(e);
                if e > 10.0 {
                    far += 1;
                    if s.flagged.contains(&plan.segment_of(r.frame)) {
                        caught += 1;
                    }
                }
            }
            let acc = mocap2d::eval::summarise(&errs);
            println!(
                "{:<8} len {:>4}: PCK@5 {:5.1} %  median {:6.2} px  flagged {:>2}/{:<2}  recall {:5.1} % of {far:>5} far  ({:.0} frames/s)",
                sc.name(),
                if len == 0 { "all".to_string() } else { len.to_string() },
                100.0 * acc.pck5,
                acc.median_px,
                s.flagged.len(),
                s.segments,
                100.0 * caught as f32 / far.max(1) as f32,
                s.tracked_frames as f64 / secs,
            );
        }
    }
    Ok(())
}
