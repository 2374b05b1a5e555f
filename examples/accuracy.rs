//! Accuracy table on synthetic clips: render → encode (mp4) → track → compare with ground truth.
//!
//!     cargo run --release --example accuracy -- [SCENARIO ...] [--size 640x360] [--frames N]
//!
//! Prints one line per scenario: median, p95, PCK@5, PCK@10 and tracking frames/s.
#[path = "common/size.rs"]
mod size;

use mocap2d::app::{track, TrackOptions};
use mocap2d::progress::NoProgress;
use mocap2d::synth::{render, write_clip, Scenario, SynthOptions};
use std::str::FromStr;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut size = (640, 360);
    let mut frames = None;
    let mut seed = 1;
    let mut scenarios = Vec::new();
    let mut memory = false;
    let mut i = 0;
    while i < args.len() {
        match args[i].as_str() {
            "--size" => {
                size = size::parse_size(&args[i + 1]).map_err(anyhow::Error::msg)?;
                i += 1;
            }
            "--frames" => {
                frames = Some(args[i + 1].parse()?);
                i += 1;
            }
            "--seed" => {
                seed = args[i + 1].parse()?;
                i += 1;
            }
            "--memory" => memory = true,
            s => scenarios.push(Scenario::from_str(s).map_err(anyhow::Error::msg)?),
        }
        i += 1;
    }
    if scenarios.is_empty() {
        scenarios = vec![
            Scenario::Walk,
            Scenario::Occlude,
            Scenario::Fast,
            Scenario::Squash,
            Scenario::Noisy,
        ];
    }
    let tmp = tempfile::tempdir()?;
    for sc in scenarios {
        let clip = render(&SynthOptions {
            scenario: sc,
            width: size.0,
            height: size.1,
            seed,
            frames,
        });
        let dir = tmp.path().join(sc.name());
        write_clip(&clip, &dir)?;
        // --memory: the rendered frames as lossless PNGs instead of the encoded clip, tracked
        // the same way, to separate tracker errors from compression and decoding.
        let input = if memory {
            let frames = dir.join("frames");
            std::fs::create_dir_all(&frames)?;
            for (i, f) in clip.frames.iter().enumerate() {
                f.save(frames.join(format!("{i:06}.png")))?;
            }
            frames
        } else {
            dir.join("clip.mp4")
        };
        let opts = TrackOptions {
            out: Some(dir.join("run")),
            params: mocap2d::app::read_params(
                std::env::var("PARAMS")
                    .ok()
                    .as_deref()
                    .map(std::path::Path::new),
            )?,
            ..TrackOptions::new(input, dir.join("joints.toml"))
        };
        let t0 = std::time::Instant::now();
        let s = track(&opts, &NoProgress)?;
        let fps = s.tracked_frames as f64 / t0.elapsed().as_secs_f64();
        let lines = mocap2d::app::eval(
            &dir.join("run"),
            &dir.join("gt.csv"),
            std::env::var("PER_JOINT").is_ok(),
        )?;
        println!(
            "{:<8} {}{}  ({:.0} frames/s, {:?})",
            sc.name(),
            if memory { "memory: " } else { "" },
            lines[0],
            fps,
            s.status_counts
        );
        for l in &lines[1..] {
            println!("    {l}");
        }
        if let Ok(keep) = std::env::var("KEEP") {
            let dst = std::path::Path::new(&keep).join(sc.name());
            let _ = std::fs::create_dir_all(&dst);
            for f in ["clip.mp4", "gt.csv", "joints.toml", "run/tracks.csv"] {
                let _ = std::fs::copy(dir.join(f), dst.join(f.replace('/', "_")));
            }
        }
    }
    Ok(())
}
