//! The pose cue around a run (`track`, `resume`: the network's pass over the clip beside the
//! tracker, then the fusion) and `mocap2d seed` (a person's seed file from one frame).

use crate::decode;
use crate::error::{Error, Result};
use crate::geom::Point;
use crate::pose::blazepose::Landmark;
use crate::pose::engine::{models_dir, OrtEngine};
use crate::pose::{self, names, ClipLandmarks, Follower, Pick};
use crate::seed::{SeedJoint, Seeds};
use crate::track::PoseMode;
use std::path::{Path, PathBuf};
use std::thread::JoinHandle;

/// The network's landmarks of a run, beside its tracks.
pub const POSE_CSV: &str = "pose.csv";

/// Whether the cue is asked for these seeds: a person's joint names and a mode other than off.
pub fn wanted(mode: PoseMode, seeds: &Seeds) -> bool {
    mode != PoseMode::Off && names::human_joints(&seed_names(seeds)).is_some()
}

fn seed_names(seeds: &Seeds) -> Vec<String> {
    seeds.joints.iter().map(|j| j.name.clone()).collect()
}

/// The network's pass over a clip on its own thread (decoding its own copy of the frames), so
/// that it overlaps the tracker's.
pub struct PosePass {
    handle: JoinHandle<Result<ClipLandmarks>>,
}

/// Loads the engine: a library or model that does not load is refused here, before anything is
/// written.
pub fn load_engine() -> Result<OrtEngine> {
    OrtEngine::load(&models_dir())
}

/// Starts the network's pass over `clip`, following the person the seeds are on.
pub fn start(
    mut engine: OrtEngine,
    clip: &Path,
    fps: Option<f64>,
    seeds: &Seeds,
) -> Result<PosePass> {
    let mut source = decode::open(clip, fps)?;
    let pick = around(seeds);
    let seed_frame = seeds.frame as usize;
    let handle = std::thread::Builder::new()
        .name("pose".into())
        .spawn(move || {
            let mut follower = Follower::new(&mut engine, pick);
            let mut out = ClipLandmarks::new();
            while let Some(frame) = source.next_frame()? {
                let look = pose::looks_at(out.len(), seed_frame);
                out.push(if look { follower.next(&frame)? } else { None });
            }
            Ok(out)
        })
        .map_err(|e| Error::Engine(format!("cannot start the pose thread: {e}")))?;
    Ok(PosePass { handle })
}

impl PosePass {
    /// The landmarks of every frame, once the pass is done.
    pub fn finish(self) -> Result<ClipLandmarks> {
        self.handle
            .join()
            .unwrap_or_else(|_| Err(Error::Engine("the pose thread panicked".into())))
    }
}

/// The rectangle around the seeds' joints, as a pick of the person they are on.
fn around(seeds: &Seeds) -> Pick {
    let (mut lo, mut hi) = (
        Point::new(f32::MAX, f32::MAX),
        Point::new(f32::MIN, f32::MIN),
    );
    for j in &seeds.joints {
        lo = Point::new(lo.x.min(j.bbox.cx), lo.y.min(j.bbox.cy));
        hi = Point::new(hi.x.max(j.bbox.cx), hi.y.max(j.bbox.cy));
    }
    Pick::Inside(lo, hi)
}

/// After a run is tracked: checks that the network is on the seeds' person (in `auto`), keeps
/// its landmarks in `pose.csv` and fuses them into `tracks.csv` ([`crate::run::fuse`]).
/// Returns a note for the user when the cue was left out.
pub fn fuse_run(
    run_dir: &Path,
    seeds: &Seeds,
    mode: PoseMode,
    lms: &ClipLandmarks,
) -> Result<Option<String>> {
    let names_ = seed_names(seeds);
    if mode == PoseMode::Auto {
        if let Some(why) = disagreement(seeds, lms) {
            let _ = std::fs::remove_file(run_dir.join(POSE_CSV));
            return Ok(Some(format!(
                "the pose cue is left out: {why} (`--pose on` uses it all the same)"
            )));
        }
    }
    crate::atomic::write(&run_dir.join(POSE_CSV), pose::to_csv(lms).as_bytes())?;
    crate::run::fuse::apply(run_dir, &names_, lms)?;
    Ok(None)
}

/// The cue of a run being resumed: its `pose.csv`, when the run has one and the cue is on.
pub fn recorded(run_dir: &Path, mode: PoseMode, frames: u64) -> Result<Option<ClipLandmarks>> {
    let path = run_dir.join(POSE_CSV);
    if mode == PoseMode::Off || !path.is_file() {
        return Ok(None);
    }
    pose::read_csv(&path, frames as usize).map(Some)
}

/// In `auto`, before tracking: why the cue is left out ([`disagreement`]), from one look at the
/// seed frame taken as the pass's first look is.
pub fn check_seed_frame(
    engine: &mut OrtEngine,
    clip: &Path,
    fps: Option<f64>,
    seeds: &Seeds,
) -> Result<Option<String>> {
    let img = decode::read_frame(clip, fps, seeds.frame)?;
    let lm = Follower::new(engine, around(seeds)).next(&img)?;
    Ok(disagreement_on(seeds, lm.as_deref()))
}

/// Why the network is not on the seeds' person on the seed frame (`None` when it is): its
/// landmarks for the seeded joints lie, in median, further from the seeds than half the torso.
fn disagreement(seeds: &Seeds, lms: &ClipLandmarks) -> Option<String> {
    disagreement_on(
        seeds,
        lms.get(seeds.frame as usize).and_then(|l| l.as_deref()),
    )
}

/// [`disagreement`] with the network's landmarks `lm` of the seed frame.
fn disagreement_on(seeds: &Seeds, lm: Option<&[Landmark]>) -> Option<String> {
    let f = seeds.frame;
    let Some(lm) = lm else {
        return Some(format!("the network sees no person on the seed frame {f}"));
    };
    let torso = pose::torso(lm).max(1.0);
    let mut d: Vec<f32> = seeds
        .joints
        .iter()
        .filter_map(|j| {
            let l = names::landmark_of(&j.name)?;
            Some((lm[l].pos - j.bbox.centre()).norm())
        })
        .collect();
    d.sort_by(f32::total_cmp);
    let median = d.get(d.len() / 2).copied().unwrap_or(f32::MAX);
    (median > 0.5 * torso).then(|| {
        format!(
            "on the seed frame {f} the network's joints lie {median:.0} px from the seeds in \
             median, more than half its torso ({torso:.0} px): it is not on the seeded person"
        )
    })
}

/// Options of `mocap2d seed`.
#[derive(Debug, Clone)]
pub struct SeedOptions {
    pub clip: PathBuf,
    pub frame: u64,
    pub out: PathBuf,
    /// Take the person inside this rectangle (x, y, w, h px) rather than the largest.
    pub within: Option<[f32; 4]>,
    pub fps: Option<f64>,
}

/// What `mocap2d seed` found.
#[derive(Debug, Clone)]
pub struct SeedSummary {
    pub people: usize,
    pub joints: usize,
    /// Joints the network is unsure of (visibility under one half).
    pub unsure: Vec<String>,
}

/// `mocap2d seed`: the seed file of the person on one frame, from the pose network: the 17
/// COCO joints rooted at the left hip, each a square sized from the body.
pub fn seed(opts: &SeedOptions) -> Result<SeedSummary> {
    let mut engine = OrtEngine::load(&models_dir())?;
    let img = decode::read_frame(&opts.clip, opts.fps, opts.frame)?;
    let pick = match opts.within {
        Some([x, y, w, h]) => Pick::Inside(Point::new(x, y), Point::new(x + w, y + h)),
        None => Pick::Largest,
    };
    let found = pose::person::find(&mut engine, &img, &[pick])?;
    let Some(lm) = found.landmarks else {
        return Err(Error::Clip {
            path: opts.clip.clone(),
            msg: match found.people {
                0 => format!(
                    "frame {}: the pose network finds no person; try another --frame",
                    opts.frame
                ),
                n => format!(
                    "frame {}: none of the {n} people found is inside --box; widen the box",
                    opts.frame
                ),
            },
        });
    };
    let pts = &lm.points;
    let side = pose::person::seed_side(pts);
    let parents: [(&str, Option<&str>); 17] = [
        ("left_hip", None),
        ("right_hip", Some("left_hip")),
        ("left_shoulder", Some("left_hip")),
        ("right_shoulder", Some("right_hip")),
        ("left_elbow", Some("left_shoulder")),
        ("right_elbow", Some("right_shoulder")),
        ("left_wrist", Some("left_elbow")),
        ("right_wrist", Some("right_elbow")),
        ("left_knee", Some("left_hip")),
        ("right_knee", Some("right_hip")),
        ("left_ankle", Some("left_knee")),
        ("right_ankle", Some("right_knee")),
        ("nose", Some("left_shoulder")),
        ("left_eye", Some("nose")),
        ("right_eye", Some("nose")),
        ("left_ear", Some("left_eye")),
        ("right_ear", Some("right_eye")),
    ];
    let mut unsure = Vec::new();
    let joints: Vec<SeedJoint> = parents
        .iter()
        .map(|(name, parent)| {
            let l = &pts[names::landmark_of(name).expect("a COCO name is a landmark")];
            if l.visibility < 0.5 {
                unsure.push(name.to_string());
            }
            SeedJoint {
                name: name.to_string(),
                bbox: pose::person::seed_box(l.pos, side, img.width(), img.height()),
                parent: parent.map(str::to_string),
                score: None,
                status: None,
                line: 0,
            }
        })
        .collect();
    let header = format!(
        "Seeds of the person on frame {} of {}, from the pose network (`mocap2d seed`).\n\
         Move any joint that is off onto the real joint before tracking.",
        opts.frame,
        opts.clip.display()
    );
    let text = crate::seed::to_toml(opts.frame, &joints, &header);
    // What is written must read back as a seed file.
    crate::seed::parse_seeds(&text, &opts.out)?;
    crate::atomic::write(&opts.out, text.as_bytes())?;
    Ok(SeedSummary {
        people: found.people,
        joints: joints.len(),
        unsure,
    })
}
