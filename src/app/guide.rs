//! `mocap2d guide CLIP --frame N --out guide.png [--seeds-out starter.toml]`: the seeding guide
//! of one frame (docs/method.md §6; see [`crate::review::guide`]).

use crate::background::BackgroundChoice;
use crate::decode::read_frame;
use crate::error::{Error, Result};
use crate::review::{draw, guide};
use std::path::PathBuf;

/// Options of `mocap2d guide`.
#[derive(Debug, Clone)]
pub struct GuideOptions {
    pub clip: PathBuf,
    /// 0-based frame to draw the guide on.
    pub frame: u64,
    /// PNG to write.
    pub out: PathBuf,
    /// Starter seed file to write; never overwrites an existing file.
    pub seeds_out: Option<PathBuf>,
    pub fps: Option<f64>,
    /// A clean plate instead of the temporal median.
    pub background: Option<PathBuf>,
}

/// What `guide` found.
#[derive(Debug, Clone)]
pub struct GuideSummary {
    pub end_points: usize,
    pub branch_points: usize,
    /// Silhouette area, px.
    pub silhouette_px: u64,
}

/// `mocap2d guide`: checks the options, builds the background model as `track` would, finds the
/// silhouette, skeleton and candidate joints of the frame, and writes the PNG (and the starter
/// seed file). Nothing is written when an input is bad.
pub fn guide(opts: &GuideOptions) -> Result<GuideSummary> {
    let ext = opts.out.extension().and_then(|e| e.to_str()).unwrap_or("");
    if !ext.eq_ignore_ascii_case("png") {
        return Err(Error::Usage(format!(
            "--out {}: the guide is a PNG image; give a path ending in .png",
            opts.out.display()
        )));
    }
    if let Some(s) = &opts.seeds_out {
        if s.exists() {
            return Err(Error::Usage(format!(
                "--seeds-out {}: the file exists and may hold your edits; the guide never \
                 overwrites a seed file: choose another name or delete it",
                s.display()
            )));
        }
    }
    let frame = read_frame(&opts.clip, opts.fps, opts.frame)?;
    let (w, h) = frame.dimensions();
    let choice = match &opts.background {
        Some(plate) => BackgroundChoice::Plate(plate.clone()),
        None => BackgroundChoice::Median,
    };
    let built = choice.build(&opts.clip, opts.fps, w, h, None)?;
    if let Some(c) = built.camera.filter(|c| c.moves()) {
        return Err(Error::Usage(format!(
            "{}: {}, so the clip's median is no picture of the background and the silhouette \
             would be wrong; give a plate of the empty scene with --background PLATE, or place \
             the seeds by hand (`mocap2d serve`)",
            opts.clip.display(),
            c.describe()
        )));
    }
    let bg = built.model.expect("a median or a plate is a model");
    let mask = guide::silhouette(&frame, &bg);
    let area = mask.pixels().filter(|p| p.0[0] != 0).count() as u64;
    if area == 0 {
        return Err(Error::Usage(format!(
            "{}: frame {}: no foreground found against the background model; the character must \
             move during the clip for the temporal median to leave it out, or give a clean plate \
             with --background PLATE",
            opts.clip.display(),
            opts.frame
        )));
    }
    let g = guide::guide_of_mask(mask);
    if g.points.is_empty() && opts.seeds_out.is_some() {
        return Err(Error::Usage(format!(
            "{}: frame {}: the silhouette's skeleton has no end or branch point (it is a closed \
             loop), so there is no starter joint to write; try another --frame",
            opts.clip.display(),
            opts.frame
        )));
    }
    let img = guide::render(&frame, &g, opts.frame);
    crate::atomic::write(&opts.out, &draw::png_bytes(&img))?;
    if let Some(s) = &opts.seeds_out {
        let joints = guide::starter_joints(&g, w, h);
        let header = format!(
            "Starter seeds from `mocap2d guide` on frame {} of {}: one joint per end (limb tip) \
             and branch point of the silhouette's skeleton, parents along the skeleton.\n\
             Rename the joints, move them onto the real joints, add the ones between (elbows, \
             knees) and delete the rest.",
            opts.frame,
            opts.clip.display()
        );
        let text = crate::seed::to_toml(opts.frame, &joints, &header);
        crate::atomic::write(s, text.as_bytes())?;
    }
    let ends = g
        .points
        .iter()
        .filter(|p| p.kind == crate::review::graph::NodeKind::End)
        .count();
    Ok(GuideSummary {
        end_points: ends,
        branch_points: g.points.len() - ends,
        silhouette_px: area,
    })
}
