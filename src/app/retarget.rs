//! `mocap2d retarget`: the captured motion onto a target character (docs/method.md §4). It
//! checks every input before writing anything.

use crate::character::read_character;
use crate::deform::{DeformOptions, Rig};
use crate::error::{Error, Result};
use crate::retarget::files::{self, RetargetManifest};
use crate::retarget::{self, RetargetOptions};
use std::path::{Path, PathBuf};

/// The folder of a run that `retarget` writes.
pub const RETARGET_DIR: &str = "retarget";

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
    /// Points the clean-up dropped as jumps and filled.
    pub dropped: usize,
    /// `(foot joint, frames on the ground)` of each foot.
    pub contacts: Vec<(String, usize)>,
}

/// `mocap2d retarget RUN --target CHARACTER`: writes `RUN/retarget/` (pose.csv, bones.csv,
/// clean.csv, contacts.csv, retarget.toml; see [`files`]).
pub fn retarget(run: &Path, target: &Path, options: &RetargetOptions) -> Result<RetargetSummary> {
    let character = read_character(target)?;
    let (width, height, fps) = run_frame(run)?;
    let seeds_path = run.join("seeds.toml");
    let (seeds, _) = crate::seed::read_seeds(&seeds_path)?;
    let mapping = retarget::mapping::build(&character, &seeds.skeleton, &seeds_path)?;
    let tracks_path = run.join("tracks.csv");
    let rows = crate::run::tracks::read_tracks(&tracks_path)?;
    let tracked = retarget::motion_from_tracks(&rows, &seeds.skeleton, &tracks_path)?;
    // Rows are every joint of every frame (checked just above); index them the same way.
    let n = seeds.skeleton.len();
    let index = |r: &crate::run::TrackRow| {
        let t = (r.frame - tracked.frames[0]) as usize;
        (t, seeds.skeleton.index_of(&r.joint).unwrap_or(0))
    };
    let mut fixed = vec![vec![false; n]; tracked.frames.len()];
    for r in &rows {
        let (t, j) = index(r);
        fixed[t][j] = r.status == "seed";
    }
    let cleaned = retarget::cleanup::clean(&tracked, &seeds.skeleton, &fixed, options.clean);
    let motion = &cleaned.motion;
    let placement = retarget::place(
        &character.skeleton,
        &character.rest,
        character.scale,
        &mapping,
        &motion.joints[0],
        &retarget::reference_lengths(&motion.joints, &mapping),
    );
    let rest_out: Vec<retarget::P64> = character.rest.iter().map(|&p| placement.apply(p)).collect();
    let r = retarget::retarget(motion, &character.skeleton, &mapping, &rest_out, options);
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
        clean: options.clean.strength,
        stretch: options.stretch,
        plant_feet: options.plant_feet,
    };
    let dir = run.join(RETARGET_DIR);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    crate::atomic::write(&dir.join("pose.csv"), files::pose_csv(&r, names).as_bytes())?;
    crate::atomic::write(
        &dir.join("bones.csv"),
        files::bones_csv(&r, names).as_bytes(),
    )?;
    crate::atomic::write(
        &dir.join("clean.csv"),
        files::clean_csv(&rows, &seeds.skeleton, motion, &cleaned.dropped).as_bytes(),
    )?;
    crate::atomic::write(
        &dir.join("contacts.csv"),
        retarget::contacts::contacts_csv(&r.frames, names, &r.legs, &r.contact).as_bytes(),
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
        dropped: cleaned.dropped_count(),
        contacts: r
            .legs
            .iter()
            .zip(&r.contact)
            .map(|(l, c)| (names[l.foot].clone(), c.iter().filter(|&&v| v).count()))
            .collect(),
    })
}

/// `mocap2d retarget --check --target CHARACTER [RUN]`: checks the character file as `retarget`
/// and `render` do (the file, its image, and the mesh `render` builds from it) and says what it
/// found, as printable lines: the joints, each with the body part mocap2d recognises in its name;
/// with a run folder, which source bone would drive which bone. Writes nothing; every problem is
/// the error `retarget` would give (exit 2, naming the file, line and joint).
pub fn check_character(target: &Path, run: Option<&Path>) -> Result<Vec<String>> {
    let character = read_character(target)?;
    let rig = Rig::for_character(&character, 1.0, DeformOptions::default()).map_err(|m| {
        Error::Character {
            path: character.path.clone(),
            line: None,
            joint: None,
            msg: format!("image {}: {m}", character.image_path.display()),
        }
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
