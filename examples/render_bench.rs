//! Throughput of `retarget` + `render`: 300 frames at 1280×720 with a ~500-vertex mesh.
//!
//!     cargo run --release --example render_bench [-- --frames 300 --target configs/characters/robot.toml]
//!
//! The motion is the ground truth of a synthetic walk (rendered at 640×360, positions doubled to
//! 1280×720: only the joint paths are needed), written as a run folder under
//! `target/bench/render/`. Prints, in frames/s: retarget (read tracks, write pose.csv), rig build
//! plus deform and draw every frame in memory (the render itself), and the whole `mocap2d render`
//! with H.264 encoding to an mp4. `scripts/bench --render` runs this.

use anyhow::{Context, Result};
use mocap2d::app::{self, RenderOptions, Renderer};
use mocap2d::character::read_character;
use mocap2d::deform::DeformOptions;
use mocap2d::geom::Point;
use mocap2d::progress::NoProgress;
use mocap2d::retarget::files::{read_manifest, read_pose};
use mocap2d::retarget::RetargetOptions;
use mocap2d::synth::{self, Scenario, SynthOptions};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn main() -> Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut args = std::env::args().skip(1);
    let (mut frames, mut target) = (300u32, root.join("configs/characters/robot.toml"));
    while let Some(a) = args.next() {
        match a.as_str() {
            "--frames" => frames = args.next().context("--frames N")?.parse()?,
            "--target" => target = PathBuf::from(args.next().context("--target FILE")?),
            _ => anyhow::bail!("usage: render_bench [--frames N] [--target CHARACTER.toml]"),
        }
    }
    let dir = root.join("target/bench/render");
    let run = dir.join("walk.mocap");
    std::fs::create_dir_all(&run)?;
    let clip = synth::render(&SynthOptions {
        scenario: Scenario::Walk,
        width: 640,
        height: 360,
        seed: 1,
        frames: Some(frames),
    });
    let mut tracks = String::from("frame,joint,x,y,angle,score,status\n");
    for (f, joints) in clip.gt.iter().enumerate() {
        for (name, (x, y)) in clip.joint_names.iter().zip(joints) {
            let _ = writeln!(
                tracks,
                "{f},{name},{:.3},{:.3},0.0000,1.000,ok",
                2.0 * x,
                2.0 * y
            );
        }
    }
    std::fs::write(run.join("tracks.csv"), tracks)?;
    let seeds = clip.seeds_toml();
    let seeds = double_xy(&seeds);
    std::fs::write(run.join("seeds.toml"), seeds)?;
    std::fs::write(
        run.join("run.toml"),
        "width = 1280\nheight = 720\nfps = 30.0\n",
    )?;

    // Retarget + rig + draw every frame in memory.
    let t0 = Instant::now();
    app::retarget(&run, &target, &RetargetOptions::default())?;
    let t_retarget = t0.elapsed().as_secs_f64();
    let ch = read_character(&target)?;
    let m = read_manifest(&run.join("retarget/retarget.toml"))?;
    let r = Renderer::new(&ch, m.scale, m.width, m.height, DeformOptions::default())?;
    let t_rig = t0.elapsed().as_secs_f64() - t_retarget;
    let (_, poses) = read_pose(&run.join("retarget/pose.csv"), &ch.skeleton.names)?;
    let t1 = Instant::now();
    let checksum: u64 = poses
        .par_chunks(8)
        .map(|chunk| {
            chunk
                .iter()
                .map(|j| {
                    let pts: Vec<Point> = j
                        .iter()
                        .map(|p| Point::new(p[0] as f32, p[1] as f32))
                        .collect();
                    let img = r.frame(&pts);
                    img.as_raw()
                        .iter()
                        .step_by(97)
                        .map(|&b| b as u64)
                        .sum::<u64>()
                })
                .sum::<u64>()
        })
        .sum();
    let t_draw = t1.elapsed().as_secs_f64();
    let total = t0.elapsed().as_secs_f64();

    // The whole command, with H.264.
    let out = dir.join("walk.mp4");
    let t2 = Instant::now();
    let opts = RenderOptions {
        run: run.clone(),
        target: target.clone(),
        out: Some(out.clone()),
        frames_dir: None,
        deform: DeformOptions::default(),
    };
    let s = app::render(&opts, &NoProgress)?;
    let t_cmd = t2.elapsed().as_secs_f64();

    let n = poses.len() as f64;
    println!(
        "### retarget + render, {} frames at 1280x720, {}",
        poses.len(),
        target.display()
    );
    println!();
    println!(
        "mesh: {} vertices, {} triangles, {} joint-area vertices; {} threads",
        s.vertices,
        s.triangles,
        s.joint_vertices,
        rayon::current_num_threads()
    );
    println!();
    println!("| stage | s | frames/s |");
    println!("|---|---:|---:|");
    println!(
        "| retarget (tracks.csv -> pose.csv) | {t_retarget:.3} | {:.0} |",
        n / t_retarget
    );
    println!("| rig (mesh, skinning, stage-two factor) | {t_rig:.3} | |");
    println!(
        "| deform + draw, in memory | {t_draw:.3} | {:.0} |",
        n / t_draw
    );
    println!(
        "| **retarget + rig + deform + draw** | {total:.3} | **{:.0}** |",
        n / total
    );
    println!(
        "| `render` with H.264 to mp4 | {t_cmd:.3} | {:.0} |",
        n / t_cmd
    );
    println!();
    println!("(pixel checksum {checksum}; video {})", out.display());
    Ok(())
}

/// The seed file with every `x = ` and `y = ` doubled (640x360 -> 1280x720).
fn double_xy(text: &str) -> String {
    text.lines()
        .map(|l| match l.split_once(" = ") {
            Some((k @ ("x" | "y"), v)) => {
                format!("{k} = {:.3}", 2.0 * v.parse::<f64>().unwrap_or(0.0))
            }
            _ => l.to_owned(),
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}
