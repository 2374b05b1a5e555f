//! `mocap2d export RUN --format F --out FILE`: a run folder in the formats animators load
//! ([`crate::export`]). Every input is checked before anything is written; files are written
//! atomically. Spine and DragonBones also write the files their main file names (atlas, texture
//! atlas, the character image copied) into `--out`'s folder, so that folder travels.

use super::retarget::{hash_file, run_frame, RETARGET_DIR};
use crate::character::{read_character, Character};
use crate::error::{Error, Result};
use crate::export::contacts::{self, ContactEvent};
use crate::export::keys::Keys;
use crate::export::{
    bvh, dlc, dragonbones, json, skin, spine, spine_rig, Animation, Format, Tracks,
};
use crate::retarget::files::{self, RetargetManifest};
use std::path::{Path, PathBuf};

/// The foot contacts `mocap2d retarget` writes in the run's retarget folder (docs/formats.md).
pub const CONTACTS_CSV: &str = "contacts.csv";

/// Options of `mocap2d export`.
#[derive(Debug, Clone)]
pub struct ExportOptions {
    pub run: PathBuf,
    pub format: Format,
    /// The target character file (Spine, DragonBones: its image is the skin; by default the one
    /// `retarget.toml` names).
    pub target: Option<PathBuf>,
    pub out: PathBuf,
    /// How Spine and DragonBones key their channels.
    pub keys: Keys,
    /// Spine: the animator's own skeleton to add the motion to, instead of a new skeleton.
    pub skeleton: Option<UserSkeleton>,
}

/// The animator's own Spine skeleton as the export's target ([`crate::export::spine_rig`]).
#[derive(Debug, Clone)]
pub struct UserSkeleton {
    /// Their Spine 4.2 skeleton JSON.
    pub path: PathBuf,
    /// The animation's name.
    pub animation: String,
    /// `--bone`: their bone and the joint it turns at (`PIVOT`, `PIVOT>JOINT`, a root joint),
    /// in the order given.
    pub bones: Vec<(String, String)>,
    /// `--bone-map`: a mapping file (`[bones]`, as the export writes it); `--bone` overrides
    /// its lines.
    pub bone_map: Option<PathBuf>,
    /// Keep IK constraints over mapped bones, moving their targets (else their mix is keyed to
    /// 0 in the animation).
    pub keep_ik: bool,
}

/// What `export` wrote.
#[derive(Debug, Clone)]
pub struct ExportSummary {
    /// Files written, the main one first.
    pub files: Vec<PathBuf>,
    pub frames: usize,
    pub joints: usize,
    /// Something the user should know (e.g. the JSON has no retargeted pose), or empty.
    pub note: String,
    /// Lines to print: with a user skeleton, which of their bones follows which joint; the
    /// contact events carried.
    pub matches: Vec<String>,
    /// What the user should check.
    pub warnings: Vec<String>,
}

/// `mocap2d export`.
pub fn export(opts: &ExportOptions) -> Result<ExportSummary> {
    let format = opts.format;
    if let (Some(t), false) = (&opts.target, format.needs_target()) {
        return Err(Error::Usage(format!(
            "--target {}: --format {} does not use a character file; leave --target out \
             (only --format spine and dragonbones take one)",
            t.display(),
            format.name()
        )));
    }
    if let (Some(u), false) = (&opts.skeleton, format == Format::Spine) {
        return Err(Error::Usage(format!(
            "--skeleton {}: only --format spine adds the motion to a skeleton of yours",
            u.path.display()
        )));
    }
    let out_dir = check_out(&opts.out)?;
    let (width, height, fps) = run_frame(&opts.run)?;
    let retarget_dir = opts.run.join(RETARGET_DIR);
    let has_retarget = retarget_dir.join("retarget.toml").is_file();
    if format.needs_retarget() && !has_retarget {
        return Err(Error::RunFolder {
            path: opts.run.clone(),
            msg: format!(
                "has no retargeted pose ({}/retarget.toml); --format {} exports the target \
                 character's motion: run `mocap2d retarget {} --target CHARACTER.toml` first \
                 (dlc-csv and json export the tracks alone)",
                RETARGET_DIR,
                format.name(),
                opts.run.display()
            ),
        });
    }
    let pose = if has_retarget && format != Format::DlcCsv {
        Some(read_animation(&opts.run, width, height)?)
    } else {
        None
    };

    let mut note = String::new();
    let mut matches = Vec::new();
    let mut warnings = Vec::new();
    let mut files_out: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let (frames, joints) = match format {
        Format::Spine if opts.skeleton.is_some() => {
            // Cannot fail: formats that need a pose loaded it above; this arm's guard.
            let (anim, _) = pose.as_ref().expect("checked above");
            let user = opts.skeleton.as_ref().expect("guard");
            let text = std::fs::read_to_string(&user.path).map_err(|e| {
                Error::Usage(format!(
                    "--skeleton {}: cannot read it ({e}); give your Spine skeleton JSON",
                    user.path.display()
                ))
            })?;
            let mut given = match &user.bone_map {
                Some(p) => read_bone_map(p)?,
                None => Vec::new(),
            };
            given.extend(
                user.bones
                    .iter()
                    .map(|(b, j)| (b.clone(), j.clone(), "--bone".to_owned())),
            );
            let mut contact_lines = Vec::new();
            let contacts = contact_events(&retarget_dir, anim, &mut contact_lines)?;
            let r = spine_rig::add_animation(
                &text,
                &user.path,
                anim,
                &spine_rig::RigOptions {
                    name: user.animation.clone(),
                    given,
                    keys: opts.keys,
                    keep_ik: user.keep_ik,
                    contacts,
                },
            )?;
            warnings = r.warnings;
            matches = r.matches;
            matches.append(&mut contact_lines);
            files_out.push((opts.out.clone(), r.text.into_bytes()));
            // The mapping file, beside --out: never over one the user may have edited.
            let map = bone_map_path(&opts.out);
            if user.bone_map.is_none() && !map.exists() {
                matches.push(format!(
                    "mapping written to {}: edit it and pass it back with --bone-map",
                    map.display()
                ));
                files_out.push((map, r.map_file.into_bytes()));
            } else if user.bone_map.is_none() {
                warnings.push(format!(
                    "{} exists and is left as it is (this mapping is printed above): pass it \
                     with --bone-map to use it, or delete it to have it written again",
                    map.display()
                ));
            }
            let from = user.path.parent().filter(|p| !p.as_os_str().is_empty());
            let same_dir = match (
                from.unwrap_or(Path::new(".")).canonicalize(),
                out_dir.canonicalize(),
            ) {
                (Ok(a), Ok(b)) => a == b,
                _ => false,
            };
            if !same_dir {
                note = format!(
                    "{} keeps the images and atlas paths of {}: put it beside them",
                    opts.out.display(),
                    user.path.display()
                );
            }
            (anim.frames.len(), anim.skeleton.len())
        }
        Format::Spine => {
            // Cannot fail: formats that need a pose loaded it above.
            let (anim, manifest) = pose.as_ref().expect("checked above");
            let character = target_character(opts, manifest, &retarget_dir)?;
            let events = contact_events(&retarget_dir, anim, &mut matches)?;
            let mesh = skin::skin_mesh(&character, manifest.placement(), &anim.joints[0])?;
            files_out.push((
                opts.out.clone(),
                spine::to_spine(anim, &mesh, opts.keys, &events).into(),
            ));
            files_out.push((opts.out.with_extension("atlas"), spine::atlas(&mesh).into()));
            files_out.push((out_dir.join(&mesh.image), read_image(&character)?));
            (anim.frames.len(), anim.skeleton.len())
        }
        Format::DragonBones => {
            // Cannot fail: formats that need a pose loaded it above.
            let (anim, manifest) = pose.as_ref().expect("checked above");
            let character = target_character(opts, manifest, &retarget_dir)?;
            let events = contact_events(&retarget_dir, anim, &mut matches)?;
            let mesh = skin::skin_mesh(&character, manifest.placement(), &anim.joints[0])?;
            let base = dragonbones_base(&opts.out);
            let (tex, png) = (format!("{base}_tex.json"), format!("{base}_tex.png"));
            files_out.push((
                opts.out.clone(),
                dragonbones::to_dragonbones(anim, &mesh, opts.keys, &events).into(),
            ));
            files_out.push((
                out_dir.join(&tex),
                dragonbones::texture_atlas(&mesh, &png).into(),
            ));
            files_out.push((out_dir.join(&png), read_image(&character)?));
            (anim.frames.len(), anim.skeleton.len())
        }
        Format::Bvh => {
            // Cannot fail: formats that need a pose loaded it above.
            let (anim, _) = pose.as_ref().expect("checked above");
            files_out.push((opts.out.clone(), bvh::to_bvh(anim).into()));
            (anim.frames.len(), anim.skeleton.len())
        }
        Format::DlcCsv => {
            let tracks = read_tracks(&opts.run)?;
            files_out.push((opts.out.clone(), dlc::to_dlc_csv(&tracks).into()));
            (tracks.frames.len(), tracks.skeleton.len())
        }
        Format::Json => {
            let tracks = read_tracks(&opts.run)?;
            let pose_ref = pose.as_ref().map(|(a, m)| (a, m.target.as_str()));
            if pose_ref.is_none() {
                note = "no retargeted pose in the run folder: \"pose\" is null (run `mocap2d \
                        retarget` first to include it)"
                    .into();
            }
            files_out.push((
                opts.out.clone(),
                json::to_json(width, height, fps, &tracks, pose_ref).into(),
            ));
            (tracks.frames.len(), tracks.skeleton.len())
        }
    };
    // Two outputs at one path (e.g. `--out robot.png` beside the image copy) would overwrite
    // each other: refused before anything is written.
    for (i, (a, _)) in files_out.iter().enumerate() {
        if files_out[..i].iter().any(|(b, _)| b == a) {
            return Err(Error::Usage(format!(
                "--out {}: the export also writes {} there; give --out another name",
                opts.out.display(),
                a.display()
            )));
        }
    }
    for (path, bytes) in &files_out {
        crate::atomic::write(path, bytes)?;
    }
    Ok(ExportSummary {
        files: files_out.into_iter().map(|(p, _)| p).collect(),
        frames,
        joints,
        note,
        matches,
        warnings,
    })
}

/// Where `export --skeleton` writes the bone mapping: beside `out`, `NAME.bones.toml`.
pub fn bone_map_path(out: &Path) -> PathBuf {
    out.with_extension("bones.toml")
}

/// The `[bones]` of a bone-map file as (bone, mapping, the file's name) in the file's order.
fn read_bone_map(path: &Path) -> Result<Vec<(String, String, String)>> {
    let bad = |msg: String| {
        Error::Usage(format!(
            "--bone-map {}: {msg}; give the file `mocap2d export --skeleton` wrote ([bones], \
             BONE = \"PIVOT\")",
            path.display()
        ))
    };
    let text = std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read it ({e})")))?;
    let doc: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| bad(format!("not TOML ({})", e.message())))?;
    let Some(toml::Value::Table(bones)) = doc.get("bones") else {
        return Err(bad("no [bones] table".into()));
    };
    let from = path.display().to_string();
    // The file's order (toml's tables are sorted; the order only matters for messages).
    bones
        .iter()
        .map(|(k, v)| match v.as_str() {
            Some(j) => Ok((k.clone(), j.to_owned(), from.clone())),
            None => Err(bad(format!(
                "{k}: expected a joint name in quotes, found {v}"
            ))),
        })
        .collect()
}

/// The foot contacts of the retarget (`contacts.csv`, when it wrote one) as events; says how
/// many in `lines`.
fn contact_events(
    retarget_dir: &Path,
    anim: &Animation,
    lines: &mut Vec<String>,
) -> Result<Vec<ContactEvent>> {
    let path = retarget_dir.join(CONTACTS_CSV);
    if !path.is_file() {
        return Ok(Vec::new());
    }
    let events = contacts::read_contacts(&path, &anim.skeleton, &anim.frames)?;
    let starts = events.iter().filter(|e| e.start).count();
    lines.push(format!(
        "{}: {starts} contact starts and {} ends as events ({}, {})",
        path.display(),
        events.len() - starts,
        contacts::CONTACT_START,
        contacts::CONTACT_END
    ));
    Ok(events)
}

/// The target character of a Spine or DragonBones export: `--target`, or else the file
/// `retarget.toml` names; either must be the file the run was retargeted onto, unchanged.
fn target_character(
    opts: &ExportOptions,
    manifest: &RetargetManifest,
    retarget_dir: &Path,
) -> Result<Character> {
    let (target, given) = match &opts.target {
        Some(t) => (t.clone(), true),
        None => (PathBuf::from(&manifest.target), false),
    };
    if !given && !target.is_file() {
        return Err(Error::Usage(format!(
            "--format {} puts the target character's image in the export, and {} was \
             retargeted onto {}, which is not found from here; give --target CHARACTER.toml",
            opts.format.name(),
            opts.run.display(),
            manifest.target
        )));
    }
    let character = read_character(&target)?;
    if character.blake3 != manifest.target_blake3 {
        return Err(Error::RunFolder {
            path: retarget_dir.to_owned(),
            msg: format!(
                "was retargeted onto {} (or that file has changed since), not {}; run \
                 `mocap2d retarget {} --target {}` first",
                manifest.target,
                target.display(),
                opts.run.display(),
                target.display()
            ),
        });
    }
    Ok(character)
}

/// The character image's bytes, copied as they are into the export.
fn read_image(character: &Character) -> Result<Vec<u8>> {
    std::fs::read(&character.image_path).map_err(|e| Error::io(&character.image_path, e))
}

/// The DragonBones base name of `out`: its file name without `_ske.json` (or, failing that,
/// without its extension), as in `walk_ske.json` -> `walk` (then `walk_tex.json`, `walk_tex.png`).
fn dragonbones_base(out: &Path) -> String {
    let name = out
        .file_name()
        .map_or(String::new(), |n| n.to_string_lossy().into_owned());
    if let Some(b) = name.strip_suffix("_ske.json").filter(|b| !b.is_empty()) {
        return b.to_owned();
    }
    out.file_stem()
        .map_or("mocap".into(), |s| s.to_string_lossy().into_owned())
}

/// The folder `--out` goes into; errors when it is missing or `out` is a folder.
fn check_out(out: &Path) -> Result<PathBuf> {
    if out.is_dir() {
        return Err(Error::Usage(format!(
            "--out {}: is a folder; give the file to write",
            out.display()
        )));
    }
    let dir = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if !dir.is_dir() {
        return Err(Error::Usage(format!(
            "--out {}: folder {} does not exist; create it first",
            out.display(),
            dir.display()
        )));
    }
    Ok(dir.to_owned())
}

/// The run's tracks, grouped by frame (skeleton from `seeds.toml`).
fn read_tracks(run: &Path) -> Result<Tracks> {
    let (seeds, _) = crate::seed::read_seeds(&run.join("seeds.toml"))?;
    let path = run.join("tracks.csv");
    let rows = crate::run::tracks::read_tracks(&path)?;
    Tracks::from_rows(rows, seeds.skeleton, &path)
}

/// The retargeted animation of `run` and its manifest; errors when the tracks changed since.
fn read_animation(run: &Path, width: u32, height: u32) -> Result<(Animation, RetargetManifest)> {
    let dir = run.join(RETARGET_DIR);
    let manifest = files::read_manifest(&dir.join("retarget.toml"))?;
    if manifest.tracks_blake3 != hash_file(&run.join("tracks.csv"))? {
        return Err(Error::RunFolder {
            path: dir,
            msg: "tracks.csv changed after the retarget; run `mocap2d retarget` again".into(),
        });
    }
    let skeleton = files::read_skeleton(&dir.join("pose.csv"), &dir.join("bones.csv"))?;
    let (frames, joints) = files::read_pose(&dir.join("pose.csv"), &skeleton.names)?;
    if frames.windows(2).any(|w| w[1] != w[0] + 1) {
        return Err(Error::RunFolder {
            path: dir.join("pose.csv"),
            msg: "frames are not consecutive; run `mocap2d retarget` again".into(),
        });
    }
    let anim = Animation {
        skeleton,
        frames,
        joints,
        fps: manifest.fps,
        width,
        height,
    };
    Ok((anim, manifest))
}
