//! `mocap2d retarget` and `mocap2d render`: the captured motion onto a target character
//! (docs/method.md §4–5). Both check every input before writing anything.

use crate::character::{read_character, Backdrop, Character};
use crate::deform::{DeformOptions, Rig};
use crate::error::{Error, Result};
use crate::geom::Point;
use crate::progress::Progress;
use crate::render::{draw_mesh, Texture};
use crate::retarget::files::{self, RetargetManifest};
use crate::retarget::{self, RetargetOptions};
use image::{RgbImage, RgbaImage};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// The folder of a run that `retarget` writes.
pub const RETARGET_DIR: &str = "retarget";

/// Frames deformed and drawn in parallel before they are written in order.
const BATCH_FRAMES: usize = 8;

/// What `retarget` did.
#[derive(Debug, Clone)]
pub struct RetargetSummary {
    pub dir: PathBuf,
    pub frames: usize,
    pub joints: usize,
    /// Output px per image px.
    pub scale: f64,
    /// Which source joints drive which target bone, one line each
    /// ([`retarget::mapping::Mapping::describe`]).
    pub mapping: Vec<String>,
}

/// `mocap2d retarget RUN --target CHARACTER`: writes `RUN/retarget/` (pose.csv, bones.csv,
/// retarget.toml; see [`files`]).
pub fn retarget(run: &Path, target: &Path, options: &RetargetOptions) -> Result<RetargetSummary> {
    let character = read_character(target)?;
    let (width, height, fps) = run_frame(run)?;
    let seeds_path = run.join("seeds.toml");
    let (seeds, _) = crate::seed::read_seeds(&seeds_path)?;
    let mapping = retarget::mapping::build(&character, &seeds.skeleton, &seeds_path)?;
    let tracks_path = run.join("tracks.csv");
    let rows = crate::run::tracks::read_tracks(&tracks_path)?;
    let motion = retarget::motion_from_tracks(&rows, &seeds.skeleton, &tracks_path)?;
    let placement = retarget::place(
        &character.skeleton,
        &character.rest,
        character.scale,
        &mapping,
        &motion.joints[0],
        &retarget::reference_lengths(&motion.joints, &mapping),
    );
    let rest_out: Vec<retarget::P64> = character.rest.iter().map(|&p| placement.apply(p)).collect();
    let r = retarget::retarget(&motion, &character.skeleton, &mapping, &rest_out, options);
    let names = &character.skeleton.names;
    let manifest = RetargetManifest {
        tool: "mocap2d".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        target: target.display().to_string(),
        target_blake3: character.blake3.clone(),
        tracks_blake3: hash_file(&tracks_path)?,
        width,
        height,
        fps,
        scale: placement.scale,
        offset_x: placement.offset[0],
        offset_y: placement.offset[1],
        smooth: options.smooth.map_or("none".into(), |s| s.to_string()),
        cartoon_strength: options.cartoon.map_or(0.0, |c| c.strength),
        cartoon_sigma_frames: options
            .cartoon
            .map_or(retarget::DEFAULT_CARTOON_SIGMA, |c| c.sigma_frames),
        keep_size: options.keep_size,
    };
    let dir = run.join(RETARGET_DIR);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    crate::atomic::write(&dir.join("pose.csv"), files::pose_csv(&r, names).as_bytes())?;
    crate::atomic::write(
        &dir.join("bones.csv"),
        files::bones_csv(&r, names).as_bytes(),
    )?;
    crate::atomic::write(
        &dir.join("retarget.toml"),
        files::manifest_toml(&manifest).as_bytes(),
    )?;
    Ok(RetargetSummary {
        dir,
        frames: r.frames.len(),
        joints: names.len(),
        scale: placement.scale,
        mapping: mapping.describe(&character.skeleton, &seeds.skeleton),
    })
}

/// `mocap2d retarget --check --target CHARACTER [RUN]`: checks the character file as `retarget`
/// and `render` do (the file, its image, and the mesh `render` builds from it) and says what it
/// found, as printable lines: the joints, each with the body part mocap2d recognises in its name;
/// with a run folder, which source bone would drive which bone. Writes nothing; every problem is
/// the error `retarget` would give (exit 2, naming the file, line and joint).
pub fn check_character(target: &Path, run: Option<&Path>) -> Result<Vec<String>> {
    let character = read_character(target)?;
    let rig = Rig::build(
        &character.image,
        &character.rest,
        &character.skeleton,
        &character.layers,
        character.mesh_vertices,
        1.0,
        DeformOptions::default(),
    )
    .map_err(|m| Error::Character {
        path: character.path.clone(),
        line: None,
        joint: None,
        msg: format!("image {}: {m}", character.image_path.display()),
    })?;
    let (w, h) = character.image.dimensions();
    let sk = &character.skeleton;
    let mut lines = vec![format!(
        "{}: ok: {} joints, {} bones; image {} ({w}x{h}); mesh {} vertices, {} triangles",
        target.display(),
        sk.len(),
        sk.bones().len(),
        character.image_path.display(),
        rig.mesh.rest.len(),
        rig.mesh.triangles.len()
    )];
    for (j, name) in sk.names.iter().enumerate() {
        let part = retarget::mapping::recognise(name)
            .map_or("not a recognised body part".into(), |p| {
                format!("recognised: {p}")
            });
        let parent = sk
            .parent(j)
            .map_or("root".to_owned(), |p| format!("parent {}", sk.names[p]));
        lines.push(format!(
            "  line {}: {name} ({parent}; {part})",
            character.lines.get(j).copied().unwrap_or(0)
        ));
    }
    if let Some(run) = run {
        let seeds_path = run.join("seeds.toml");
        let (seeds, _) = crate::seed::read_seeds(&seeds_path)?;
        let mapping = retarget::mapping::build(&character, &seeds.skeleton, &seeds_path)?;
        lines.push(format!("bones (target <- source, {}):", run.display()));
        lines.extend(
            mapping
                .describe(sk, &seeds.skeleton)
                .into_iter()
                .map(|l| format!("  {l}")),
        );
    }
    Ok(lines)
}

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
}

/// Everything needed to draw frames of one character: its rig, texture and backdrop.
pub struct Renderer {
    pub rig: Rig,
    pub texture: Texture,
    /// The frame before the character is drawn (output size).
    pub backdrop: RgbaImage,
}

impl Renderer {
    /// Builds the rig of `character` at `scale` output px per image px over a
    /// `width × height` backdrop. Errors name the character file.
    pub fn new(
        character: &Character,
        scale: f64,
        width: u32,
        height: u32,
        deform: DeformOptions,
    ) -> Result<Renderer> {
        let err = |msg: String| Error::Character {
            path: character.path.clone(),
            line: None,
            joint: None,
            msg,
        };
        let backdrop = match &character.backdrop {
            Backdrop::Colour([r, g, b]) => {
                RgbaImage::from_pixel(width, height, image::Rgba([*r, *g, *b, 255]))
            }
            Backdrop::Transparent => RgbaImage::new(width, height),
            Backdrop::Plate(p) => {
                let img = image::open(p)
                    .map_err(|e| err(format!("`background` image {}: {e}", p.display())))?
                    .to_rgb8();
                if img.dimensions() != (width, height) {
                    return Err(err(format!(
                        "`background` image {} is {}×{} px but the run's frames are \
                         {width}×{height}; give a frame-sized plate",
                        p.display(),
                        img.width(),
                        img.height()
                    )));
                }
                image::DynamicImage::ImageRgb8(img).to_rgba8()
            }
        };
        let rig = Rig::build(
            &character.image,
            &character.rest,
            &character.skeleton,
            &character.layers,
            character.mesh_vertices,
            scale as f32,
            deform,
        )
        .map_err(|m| err(format!("image {}: {m}", character.image_path.display())))?;
        Ok(Renderer {
            rig,
            texture: Texture::new(&character.image),
            backdrop,
        })
    }

    /// One frame with the character's joints at `joints` (output px).
    pub fn frame(&self, joints: &[Point]) -> RgbaImage {
        let pos = self.rig.deform(joints);
        let mut frame = self.backdrop.clone();
        draw_mesh(
            &mut frame,
            &pos,
            &self.rig.mesh.rest,
            &self.rig.mesh.triangles,
            &self.rig.draw_order,
            &self.texture,
        );
        frame
    }
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
            type Drawn = (RgbaImage, Option<Result<Vec<u8>>>);
            let drawn: Vec<Drawn> = chunk_joints
                .par_iter()
                .map(|j| {
                    let pts: Vec<Point> = j
                        .iter()
                        .map(|p| Point::new(p[0] as f32, p[1] as f32))
                        .collect();
                    let img = renderer.frame(&pts);
                    let png = opts
                        .frames_dir
                        .as_ref()
                        .map(|_| encode_png(&img, transparent));
                    (img, png)
                })
                .collect();
            for (&f, (img, png)) in chunk_frames.iter().zip(drawn) {
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

/// Width, height (px) and frame rate (frames/s) of a run, from its `run.toml` (only those keys
/// are read, so manifests of other versions work).
pub fn run_frame(run: &Path) -> Result<(u32, u32, f64)> {
    let path = run.join("run.toml");
    let err = |msg: String| Error::RunFolder {
        path: path.clone(),
        msg,
    };
    if !run.is_dir() {
        return Err(Error::RunFolder {
            path: run.to_owned(),
            msg: "not a folder; give a run folder written by `mocap2d track`".into(),
        });
    }
    let text = std::fs::read_to_string(&path).map_err(|e| {
        err(format!(
            "cannot read the run manifest ({e}); is this a folder written by `mocap2d track`?"
        ))
    })?;
    let t: toml::Table = toml::from_str(&text).map_err(|e| err(e.message().to_owned()))?;
    let int = |k: &str| t.get(k).and_then(toml::Value::as_integer);
    let fps = t
        .get("fps")
        .and_then(|v| v.as_float().or(v.as_integer().map(|i| i as f64)));
    match (int("width"), int("height"), fps) {
        (Some(w), Some(h), Some(f)) if w > 0 && h > 0 && w <= 8192 && h <= 8192 && f > 0.0 => {
            Ok((w as u32, h as u32, f))
        }
        _ => Err(err(
            "needs `width`, `height` (px) and `fps` (frames/s); it may be damaged".into(),
        )),
    }
}

pub(crate) fn hash_file(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|e| Error::RunFolder {
        path: path.to_owned(),
        msg: format!("cannot read: {e}"),
    })?;
    Ok(blake3::hash(&bytes).to_hex().to_string())
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
