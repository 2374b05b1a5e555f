//! `mocap2d render`: the target character deformed and drawn along the retargeted motion
//! (docs/method.md §5), as a video and/or PNG frames. It checks every input before writing
//! anything.

use super::retarget::{hash_file, RETARGET_DIR};
use crate::character::{read_character, Backdrop};
use crate::deform::DeformOptions;
use crate::error::{Error, Result};
use crate::geom::Point;
use crate::progress::Progress;
use crate::render::Renderer;
use crate::retarget::files::{self, RetargetManifest};
use image::{RgbImage, RgbaImage};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Frames deformed and drawn in parallel before they are written in order.
const BATCH_FRAMES: usize = 8;

/// Options of `mocap2d render`.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    pub run: PathBuf,
    pub target: PathBuf,
    /// Video file to write (H.264 in .mp4/.mkv/.mov, .avi).
    pub out: Option<PathBuf>,
    /// Folder for PNG frames (`000123.png`, the frame index).
    pub frames_dir: Option<PathBuf>,
    pub deform: DeformOptions,
}

/// What `render` did.
#[derive(Debug, Clone)]
pub struct RenderSummary {
    pub frames: usize,
    pub vertices: usize,
    pub triangles: usize,
    pub joint_vertices: usize,
    /// Frames whose mesh has a folded or cracked triangle (docs/method.md §5.8).
    pub defect_frames: Vec<u64>,
}

/// `mocap2d render`: deforms the target character along `RUN/retarget/pose.csv` and writes the
/// video and/or PNG frames.
pub fn render(opts: &RenderOptions, progress: &dyn Progress) -> Result<RenderSummary> {
    if opts.out.is_none() && opts.frames_dir.is_none() {
        return Err(Error::Usage(
            "render needs --out VIDEO, --frames-dir DIR or both".into(),
        ));
    }
    let character = read_character(&opts.target)?;
    let dir = opts.run.join(RETARGET_DIR);
    let manifest = files::read_manifest(&dir.join("retarget.toml"))?;
    if manifest.target_blake3 != character.blake3 {
        return Err(Error::RunFolder {
            path: dir.clone(),
            msg: format!(
                "was retargeted onto {} (or that file has changed since), not {}; run \
                 `mocap2d retarget {} --target {}` first",
                manifest.target,
                opts.target.display(),
                opts.run.display(),
                opts.target.display()
            ),
        });
    }
    if manifest.tracks_blake3 != hash_file(&opts.run.join("tracks.csv"))? {
        return Err(Error::RunFolder {
            path: dir.clone(),
            msg: "tracks.csv changed after the retarget; run `mocap2d retarget` again".into(),
        });
    }
    let (frames, joints) = files::read_pose(&dir.join("pose.csv"), &character.skeleton.names)?;
    if let Some(out) = &opts.out {
        check_video_path(out)?;
    }
    if let Some(d) = &opts.frames_dir {
        if d.exists() && !d.is_dir() {
            return Err(Error::Usage(format!(
                "{}: exists and is not a folder; choose another --frames-dir",
                d.display()
            )));
        }
    }
    let renderer = Renderer::new(
        &character,
        manifest.scale,
        manifest.width,
        manifest.height,
        opts.deform,
    )?;
    let transparent = character.backdrop == Backdrop::Transparent;

    // Everything checked: write.
    let mut written: Vec<PathBuf> = Vec::new();
    let mut defect_frames: Vec<u64> = Vec::new();
    let created_dir = opts.frames_dir.as_ref().filter(|d| !d.exists()).cloned();
    let result = (|| -> Result<()> {
        if let Some(d) = &opts.frames_dir {
            std::fs::create_dir_all(d).map_err(|e| Error::io(d, e))?;
        }
        let mut video = open_video(opts.out.as_deref(), &manifest)?;
        progress.start("render", Some(frames.len() as u64));
        for (chunk_frames, chunk_joints) in
            frames.chunks(BATCH_FRAMES).zip(joints.chunks(BATCH_FRAMES))
        {
            type Drawn = (RgbaImage, Option<Result<Vec<u8>>>, bool);
            let drawn: Vec<Drawn> = chunk_joints
                .par_iter()
                .map(|j| {
                    let pts: Vec<Point> = j
                        .iter()
                        .map(|p| Point::new(p[0] as f32, p[1] as f32))
                        .collect();
                    let (img, defects) = renderer.frame_checked(&pts);
                    let png = opts
                        .frames_dir
                        .as_ref()
                        .map(|_| encode_png(&img, transparent));
                    (img, png, !defects.is_clean())
                })
                .collect();
            for (&f, (img, png, bad)) in chunk_frames.iter().zip(drawn) {
                if bad {
                    defect_frames.push(f);
                }
                if let (Some(d), Some(png)) = (&opts.frames_dir, png) {
                    let p = d.join(format!("{f:06}.png"));
                    crate::atomic::write(&p, &png?)?;
                    written.push(p);
                }
                write_video_frame(&mut video, &img)?;
                if !progress.advance(1) {
                    return Err(Error::Interrupted);
                }
            }
        }
        progress.finish();
        finish_video(video)
    })();
    if let Err(e) = result {
        progress.finish();
        for p in &written {
            let _ = std::fs::remove_file(p);
        }
        if let Some(d) = created_dir {
            let _ = std::fs::remove_dir(d);
        }
        return Err(e);
    }
    Ok(RenderSummary {
        frames: frames.len(),
        vertices: renderer.rig.mesh.rest.len(),
        triangles: renderer.rig.mesh.triangles.len(),
        joint_vertices: renderer.rig.joint_vertex_count(),
        defect_frames,
    })
}

fn encode_png(img: &RgbaImage, keep_alpha: bool) -> Result<Vec<u8>> {
    let mut out = std::io::Cursor::new(Vec::new());
    let r = if keep_alpha {
        img.write_to(&mut out, image::ImageFormat::Png)
    } else {
        to_rgb(img).write_to(&mut out, image::ImageFormat::Png)
    };
    r.map_err(|e| Error::Encode {
        path: PathBuf::from("frame.png"),
        msg: e.to_string(),
    })?;
    Ok(out.into_inner())
}

/// Drops alpha (the colours are premultiplied, so a transparent backdrop shows black).
fn to_rgb(img: &RgbaImage) -> RgbImage {
    let (w, h) = img.dimensions();
    let mut out = Vec::with_capacity(w as usize * h as usize * 3);
    for p in img.as_raw().chunks_exact(4) {
        out.extend_from_slice(&p[..3]);
    }
    // Cannot fail: `out` holds exactly w*h RGB pixels (one per RGBA pixel).
    RgbImage::from_raw(w, h, out).expect("sized above")
}

#[cfg(feature = "ffmpeg")]
type Video = Option<crate::encode::VideoWriter>;
#[cfg(not(feature = "ffmpeg"))]
type Video = ();

#[cfg(feature = "ffmpeg")]
fn check_video_path(out: &Path) -> Result<()> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("mp4" | "m4v" | "mov" | "mkv" | "avi")) {
        return Err(Error::Usage(format!(
            "--out {}: unknown video type; end the name in .mp4, .mkv, .mov or .avi",
            out.display()
        )));
    }
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        if !parent.is_dir() {
            return Err(Error::Usage(format!(
                "--out {}: folder {} does not exist",
                out.display(),
                parent.display()
            )));
        }
    }
    Ok(())
}

#[cfg(not(feature = "ffmpeg"))]
fn check_video_path(out: &Path) -> Result<()> {
    Err(Error::Usage(format!(
        "--out {}: this build has no FFmpeg (feature `ffmpeg`); write PNG frames with --frames-dir",
        out.display()
    )))
}

#[cfg(feature = "ffmpeg")]
fn open_video(out: Option<&Path>, m: &RetargetManifest) -> Result<Video> {
    out.map(|p| crate::encode::VideoWriter::create(p, m.width, m.height, m.fps, 18))
        .transpose()
}

#[cfg(not(feature = "ffmpeg"))]
fn open_video(_: Option<&Path>, _: &RetargetManifest) -> Result<Video> {
    Ok(())
}

#[cfg(feature = "ffmpeg")]
fn write_video_frame(video: &mut Video, img: &RgbaImage) -> Result<()> {
    match video {
        Some(v) => v.write(&to_rgb(img)),
        None => Ok(()),
    }
}

#[cfg(not(feature = "ffmpeg"))]
fn write_video_frame(_: &mut Video, _: &RgbaImage) -> Result<()> {
    Ok(())
}

#[cfg(feature = "ffmpeg")]
fn finish_video(video: Video) -> Result<()> {
    video.map_or(Ok(()), |v| v.finish())
}

#[cfg(not(feature = "ffmpeg"))]
fn finish_video(_: Video) -> Result<()> {
    Ok(())
}
