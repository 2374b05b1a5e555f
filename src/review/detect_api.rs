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
use crate::pose::{names, person, Pick};
use serde_json::{json, Value};
use std::sync::Mutex;

/// Below this visibility the page names a proposed joint as one the network is unsure of.
const UNSURE: f32 = 0.5;

/// The pose engine of a server: loaded at the first Detect, kept for the next.
#[derive(Default)]
pub struct Detector {
    engine: Mutex<Option<OrtEngine>>,
}

impl Api {
    /// Why this run gets no Detect, if it gets none: its joints name no person's body.
    pub(super) fn no_detect(&self) -> Option<String> {
        let names_ = self.names();
        names::human_joints(&names_).is_none().then(|| {
            format!(
                "Detect finds people, and this run's joints ({}) do not name a person's body: \
                 it needs a shoulder, a hip and an elbow or knee named as COCO or MediaPipe name \
                 them (left_shoulder, hip_l, l_knee, …). Drag the joints by hand.",
                names_.join(", ")
            )
        })
    }

    /// `POST /api/frames/N/detect` (see the module doc).
    pub fn detect(&self, n: &str) -> Reply {
        let Ok(f) = n.parse::<u64>() else {
            return Reply::error(404, format!("no frame {n:?}: frames are numbers"));
        };
        if let Some(why) = self.no_detect() {
            return Reply::error(400, why);
        }
        if let Some(n) = self.clip_frames().filter(|&n| f >= n) {
            return Reply::error(
                404,
                format!(
                    "frame {f} is beyond the clip: it has {n} frames (0 to {})",
                    n - 1
                ),
            );
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
        let mut engine = self
            .detector
            .engine
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        if engine.is_none() {
            match OrtEngine::load(&models_dir()) {
                Ok(e) => *engine = Some(e),
                Err(e) => return Reply::error(503, cannot_load(&e)),
            }
        }
        let eng = engine.as_mut().expect("loaded above");
        let picks: Vec<Pick> = person::around(&tracked)
            .into_iter()
            .chain([Pick::Largest])
            .collect();
        let found = match person::find(eng, &img, &picks) {
            Ok(found) => found,
            Err(e) => return Reply::error(500, format!("Detect failed: {e}")),
        };
        drop(engine);
        let (Some(lm), Some((_, pick))) = (found.landmarks, found.person) else {
            return Reply::error(
                422,
                format!(
                    "the pose network finds no person on frame {f}; key the joints by hand or \
                     try a nearby frame"
                ),
            );
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
        let unsure: Vec<&str> = p
            .joints
            .iter()
            .filter(|j| j.visibility.is_some_and(|v| v < UNSURE))
            .map(|j| j.name.as_str())
            .collect();
        let kept: Vec<&str> = p
            .joints
            .iter()
            .filter(|j| j.visibility.is_none())
            .map(|j| j.name.as_str())
            .collect();
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
        let mut message = format!(
            "Proposed {} joints on frame {f} from the pose network ({chosen}{}); not saved: \
             drag any that are off, then Save key.",
            p.joints.len() - kept.len(),
            if found.people > 1 {
                format!(", of {} people found", found.people)
            } else {
                String::new()
            }
        );
        if !unsure.is_empty() {
            message += &format!(" The network is unsure of {}.", unsure.join(", "));
        }
        if !kept.is_empty() {
            message += &format!(
                " It has no landmark for {}: left where tracked.",
                kept.join(", ")
            );
        }
        Reply::json(
            200,
            &json!({
                "frame": f, "saved": false, "joints": joints, "people": found.people,
                "chosen": chosen, "person": lm.person, "mirrored": p.mirrored,
                "unsure": unsure, "kept": kept, "message": message,
            }),
        )
    }
}

/// The page's message when the engine or a model cannot be loaded (`e` names the path).
fn cannot_load(e: &crate::error::Error) -> String {
    format!(
        "Detect needs the pose network, which cannot be loaded: {e}. For Detect: run `bash \
         scripts/setup` (it installs ONNX Runtime) and keep the repository's models/ folder (or \
         set MOCAP2D_MODELS to it), then press Detect again: the server looks for them at every \
         press until they load. The rest of this page works without it."
    )
}
