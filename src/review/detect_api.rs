//! The correction page's Detect button (docs/method.md §2.8):
//! `POST /api/frames/N/detect` proposes a key on frame N from the pose network and writes
//! nothing. The page shows the proposal as joints moved but not saved; the user adjusts them
//! and saves them as any key (`POST /api/keys`, [`super::keys_api`]).
//!
//! The person is found as `mocap2d seed` finds one ([`crate::pose::person::find`]): the one
//! whose box overlaps the run's tracked body on that frame most, else the largest. The
//! landmarks become the skeleton's joints by their names, left and right settled by the
//! tracked positions ([`crate::pose::person::propose`]); a joint the network has no landmark
//! for keeps its tracked position and is marked `"from": "tracked"`.
//!
//! The engine is loaded at the first Detect and kept for the next ones (one at a time). Like
//! every answer of the page, this one is worked out on the server's blocking pool, never on the
//! thread that serves the connections ([`super::http`]). When the engine or a model cannot be
//! loaded the answer is 503 saying what is missing and the fix, and the server carries on; a
//! run whose skeleton is not a person's gets 400, and `GET /api/run` says why in `no_detect`
//! so that the page disables the button.

use super::api::Api;
use super::reply::Reply;
use crate::geom::Point;
use crate::pose::engine::{models_dir, OrtEngine};
use crate::pose::person::{self, Found};
use crate::pose::{names, Pick};
use image::RgbImage;
use serde_json::{json, Value};
use std::sync::Mutex;

/// Below this visibility the page names a proposed joint as one the network is unsure of.
const UNSURE: f32 = 0.5;

/// The pose engine of a server: loaded at the first Detect, kept for the next.
#[derive(Default)]
pub struct Detector {
    engine: Mutex<Option<OrtEngine>>,
}

impl Detector {
    /// The person the first of `picks` that chooses anyone chooses on `img`
    /// ([`person::find`]), with the engine kept (loaded at the first call); else the error
    /// reply: 503 when the engine or a model cannot be loaded ([`cannot_load`]), 500 when the
    /// network fails.
    pub(super) fn find(&self, img: &RgbImage, picks: &[Pick]) -> Result<Found, Reply> {
        let mut engine = self.engine.lock().unwrap_or_else(|e| e.into_inner());
        if engine.is_none() {
            match OrtEngine::load(&models_dir()) {
                Ok(e) => *engine = Some(e),
                Err(e) => return Err(Reply::error(503, cannot_load(&e))),
            }
        }
        let eng = engine.as_mut().expect("loaded above");
        person::find(eng, img, picks).map_err(|e| Reply::error(500, format!("Detect failed: {e}")))
    }
}

/// Why joints named `names_` get no Detect, if they get none: they name no person's body.
/// `whose` says whose joints they are ("this run's").
pub(super) fn no_detect(names_: &[String], whose: &str) -> Option<String> {
    names::human_joints(names_).is_none().then(|| {
        format!(
            "Detect finds people, and {whose} joints ({}) do not name a person's body: it needs \
             a shoulder, a hip and an elbow or knee named as COCO or MediaPipe name them \
             (left_shoulder, hip_l, l_knee, …). Drag the joints by hand.",
            names_.join(", ")
        )
    })
}

/// The 404 reply for frame `f` of a clip of `frames` frames, when it is beyond it.
pub(super) fn beyond_clip(f: u64, frames: Option<u64>) -> Option<Reply> {
    let n = frames.filter(|&n| f >= n)?;
    Some(Reply::error(
        404,
        format!(
            "frame {f} is beyond the clip: it has {n} frames (0 to {})",
            n.saturating_sub(1)
        ),
    ))
}

/// The 422 reply when the network finds no person on frame `f`.
pub(super) fn no_person(f: u64) -> Reply {
    Reply::error(
        422,
        format!(
            "the pose network finds no person on frame {f}; place the joints by hand or try a \
             nearby frame"
        ),
    )
}

/// What a Detect proposal tells the page, beside its joints.
pub(super) struct Told {
    /// Joints the network is unsure of.
    pub unsure: Vec<String>,
    /// Joints it has no landmark for, which keep their position.
    pub kept: Vec<String>,
    pub message: String,
}

/// The joints of proposal `p` the network is unsure of, those it kept, and the page's message:
/// `chosen` says which person, `kept_at` where the kept joints stay ("tracked"), `save` the
/// button that saves the proposal.
pub(super) fn told(
    p: &person::Proposal,
    f: u64,
    people: usize,
    chosen: &str,
    kept_at: &str,
    save: &str,
) -> Told {
    let names_of = |keep: &dyn Fn(Option<f32>) -> bool| -> Vec<String> {
        p.joints
            .iter()
            .filter(|j| keep(j.visibility))
            .map(|j| j.name.clone())
            .collect()
    };
    let unsure = names_of(&|v| v.is_some_and(|v| v < UNSURE));
    let kept = names_of(&|v| v.is_none());
    let mut message = format!(
        "Proposed {} joints on frame {f} from the pose network ({chosen}{}); not saved: drag \
         any that are off, then {save}.",
        p.joints.len() - kept.len(),
        if people > 1 {
            format!(", of {people} people found")
        } else {
            String::new()
        }
    );
    if !unsure.is_empty() {
        message += &format!(" The network is unsure of {}.", unsure.join(", "));
    }
    if !kept.is_empty() {
        message += &format!(
            " It has no landmark for {}: left where {kept_at}.",
            kept.join(", ")
        );
    }
    Told {
        unsure,
        kept,
        message,
    }
}

impl Api {
    /// Why this run gets no Detect, if it gets none: its joints name no person's body.
    pub(super) fn no_detect(&self) -> Option<String> {
        no_detect(&self.names(), "this run's")
    }

    /// `POST /api/frames/N/detect` (see the module doc).
    pub fn detect(&self, n: &str) -> Reply {
        let Ok(f) = n.parse::<u64>() else {
            return Reply::error(404, format!("no frame {n:?}: frames are numbers"));
        };
        if let Some(why) = self.no_detect() {
            return Reply::error(400, why);
        }
        if let Some(r) = beyond_clip(f, self.clip_frames()) {
            return r;
        }
        if self.resuming() {
            return Reply::error(
                409,
                "a resume started from this page is tracking the run again; press Detect once \
                 it is done",
            );
        }
        let rows = match self.tracks() {
            Ok(r) => r,
            Err(e) => return self.no_tracks(e),
        };
        let names_ = self.names();
        let mut tracked = Vec::with_capacity(names_.len());
        for name in &names_ {
            match rows.iter().find(|r| r.frame == f && &r.joint == name) {
                Some(r) => tracked.push(Point::new(r.x, r.y)),
                None => {
                    return Reply::error(
                        404,
                        format!("frame {f} has no tracked position of {name} in tracks.csv"),
                    )
                }
            }
        }
        let img = match self
            .any_frame
            .image(&self.clip, Some(self.data.manifest.fps), f)
        {
            Ok(i) => i,
            Err(r) => return r,
        };
        let picks: Vec<Pick> = person::around(&tracked)
            .into_iter()
            .chain([Pick::Largest])
            .collect();
        let found = match self.detector.find(&img, &picks) {
            Ok(found) => found,
            Err(r) => return r,
        };
        let (Some(lm), Some((_, pick))) = (found.landmarks, found.person) else {
            return no_person(f);
        };
        let m = &self.data.manifest;
        let Some(p) = person::propose(&lm.points, &names_, &tracked, m.width, m.height) else {
            return Reply::error(400, self.no_detect().unwrap_or_default());
        };
        let chosen = if picks.len() > 1 && pick == 0 {
            "the person around the tracked body"
        } else {
            "the largest person (none is around the tracked body)"
        };
        let t = told(&p, f, found.people, chosen, "tracked", "Save key");
        let joints: Vec<Value> = p
            .joints
            .iter()
            .map(|j| {
                json!({
                    "name": j.name, "x": j.pos.x, "y": j.pos.y, "visibility": j.visibility,
                    "from": if j.visibility.is_some() { "network" } else { "tracked" },
                })
            })
            .collect();
        Reply::json(
            200,
            &json!({
                "frame": f, "saved": false, "joints": joints, "people": found.people,
                "chosen": chosen, "person": lm.person, "mirrored": p.mirrored,
                "unsure": t.unsure, "kept": t.kept, "message": t.message,
            }),
        )
    }
}

/// The page's message when the engine or a model cannot be loaded (`e` names the path).
pub(super) fn cannot_load(e: &crate::error::Error) -> String {
    format!(
        "Detect needs the pose network, which cannot be loaded: {e}. For Detect: run `bash \
         scripts/setup` (it installs ONNX Runtime) and keep the repository's models/ folder (or \
         set MOCAP2D_MODELS to it), then press Detect again: the server looks for them at every \
         press until they load. The rest of this page works without it."
    )
}
