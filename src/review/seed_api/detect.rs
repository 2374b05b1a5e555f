//! The seeding page's Detect button (docs/guide.md, "serve"): `POST /api/frames/N/detect`
//! proposes the skeleton's joints on frame N of the clip from the pose network, with the
//! rectangles `mocap2d seed` gives a person's joints ([`person::seed_side`],
//! [`person::seed_box`]), and writes nothing. The page moves its rectangles there as unsaved
//! edits; the user adjusts them and saves with Save seeds.
//!
//! The body may carry the joints placed so far, `{"joints": [{"name", "x", "y"}, …]}`: the
//! person is then the one whose box overlaps them most, else the largest (as the correction
//! page's Detect picks around the tracked body, [`super::super::detect_api`]). The sides are
//! the network's own (a bare clip has no tracked body to settle them), and a joint the network
//! has no landmark for keeps its position, marked `"from": "placed"`.
//!
//! Answers as the correction page's Detect does: 400 for a skeleton that is not a person's (its
//! reason also in `GET /api/run` as `no_detect`), 404 for a frame beyond the clip, 503 when the
//! engine or a model cannot be loaded (the server carries on), 422 when no person is found.
//! The engine is loaded at the first Detect and kept ([`super::super::detect_api::Detector`]).

use super::super::detect_api::{beyond_clip, no_detect, no_person, told};
use super::super::reply::{json_body, Reply};
use super::SeedApi;
use crate::geom::{JointBox, Point};
use crate::pose::{person, Pick};
use serde::Deserialize;
use serde_json::{json, Value};

/// A Detect request's body: the joints placed so far (none, for an empty body).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct DetectBody {
    #[serde(default)]
    joints: Vec<Placed>,
}

/// A joint where the page has placed it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Placed {
    name: String,
    x: f32,
    y: f32,
}

impl SeedApi {
    fn names(&self) -> Vec<String> {
        self.seeds.joints.iter().map(|j| j.name.clone()).collect()
    }

    /// Why this skeleton gets no Detect, if it gets none (`GET /api/run`'s `no_detect`).
    pub(super) fn no_detect(&self) -> Option<String> {
        no_detect(&self.names(), "this skeleton's")
    }

    /// `POST /api/frames/N/detect` (see the module doc).
    pub(super) fn detect(&self, n: &str, body: &[u8]) -> Reply {
        let Ok(f) = n.parse::<u64>() else {
            return Reply::error(404, format!("no frame {n:?}: frames are numbers"));
        };
        if let Some(why) = self.no_detect() {
            return Reply::error(400, why);
        }
        if let Some(r) = beyond_clip(f, self.frames) {
            return r;
        }
        let body: DetectBody = if body.iter().all(u8::is_ascii_whitespace) {
            DetectBody::default()
        } else {
            match json_body(
                body,
                r#"{"joints": [{"name", "x", "y"}, …]} (the joints placed)"#,
            ) {
                Ok(b) => b,
                Err(r) => return r,
            }
        };
        let names_ = self.names();
        if let Some(p) = body.joints.iter().find(|p| !names_.contains(&p.name)) {
            return Reply::error(
                400,
                format!(
                    "no joint {:?} in the skeleton {}",
                    p.name,
                    self.skeleton.display()
                ),
            );
        }
        // Where each joint is now: as placed on the page, else as in the skeleton.
        let at: Vec<Point> = self
            .seeds
            .joints
            .iter()
            .map(|j| {
                body.joints
                    .iter()
                    .find(|p| p.name == j.name)
                    .map_or(j.bbox.centre(), |p| Point::new(p.x, p.y))
            })
            .collect();
        let placed: Vec<Point> = body.joints.iter().map(|p| Point::new(p.x, p.y)).collect();
        let around = person::around(&placed);
        let picks: Vec<Pick> = around.into_iter().chain([Pick::Largest]).collect();
        let img = match self.cache.image(&self.clip, None, f) {
            Ok(i) => i,
            Err(r) => return r,
        };
        let found = match self.detector.find(&img, &picks) {
            Ok(found) => found,
            Err(r) => return r,
        };
        let (Some(lm), Some((_, pick))) = (found.landmarks, found.person) else {
            return no_person(f);
        };
        let (w, h) = (self.width, self.height);
        let Some(p) = person::propose_as_named(&lm.points, &names_, &at, w, h) else {
            return Reply::error(400, self.no_detect().unwrap_or_default());
        };
        let chosen = match (around.is_some(), pick) {
            (true, 0) => "the person around the placed joints",
            (true, _) => "the largest person (none is around the placed joints)",
            (false, _) => "the largest person",
        };
        let t = told(&p, f, found.people, chosen, "placed", "Save seeds");
        let side = person::seed_side(&lm.points);
        let joints: Vec<Value> = p
            .joints
            .iter()
            .zip(&self.seeds.joints)
            .map(|(j, s)| {
                let (b, from) = match j.visibility {
                    Some(_) => (person::seed_box(j.pos, side, w, h), "network"),
                    None => (
                        JointBox {
                            cx: j.pos.x,
                            cy: j.pos.y,
                            ..s.bbox
                        },
                        "placed",
                    ),
                };
                json!({
                    "name": j.name, "x": b.cx, "y": b.cy, "w": b.w, "h": b.h, "angle": b.angle_rad,
                    "visibility": j.visibility, "from": from,
                })
            })
            .collect();
        Reply::json(
            200,
            &json!({
                "frame": f, "saved": false, "joints": joints, "people": found.people,
                "chosen": chosen, "person": lm.person, "side": side, "unsure": t.unsure,
                "kept": t.kept, "message": t.message,
            }),
        )
    }
}
