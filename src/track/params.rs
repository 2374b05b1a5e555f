//! Tracking parameters: every knob of [`super::Tracker`], with its unit and default. A run records
//! the values it used in `run.toml`; `--params FILE` overrides any of them.

use serde::{Deserialize, Serialize};

/// Tracking parameters (all recorded in `run.toml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrackParams {
    /// Smallest search radius (px) of a root, and smallest arc (px) swept by a bone's end.
    pub search_min_px: f32,
    /// Largest search radius (px) of a root.
    pub search_max_px: f32,
    /// Search window half-size in standard deviations of the prediction.
    pub search_sigmas: f32,
    /// Grid step (px, at a bone's end) of the coarse search.
    pub search_step_px: f32,
    /// Most grid steps each side of a search window's centre: a wider window is walked at the
    /// step doubled until it fits, and its 4 best points refined down to a quarter step.
    pub search_max_steps: u32,
    /// A search moves a bone off its prediction only if that lowers its mean robust colour cost
    /// (0–1) by more than this.
    pub move_evidence: f32,
    /// No search where the prediction costs no more than this over what the bones cost when in
    /// place (mean robust colour cost, 0–1, learnt as the clip goes): the refinement alone
    /// takes it from there.
    pub search_skip_cost: f32,
    /// Narrowest and widest angle window of a bone, each side of the prediction (degrees).
    pub angle_min_deg: f32,
    pub angle_max_deg: f32,
    /// Narrowest and widest length window of a bone, each side of the prediction (share of its
    /// length).
    pub stretch_min: f32,
    pub stretch_max: f32,
    /// W_g of docs/method.md eq. 7–8: the cost, against a bone's mean robust colour cost (0–1), of
    /// being at the edge of the search window.
    pub geo_weight: f32,
    /// Weight of each bone's colour term in the refinement, against the priors (per px²).
    pub colour_weight: f32,
    /// Weight of the motion prior in the refinement (scales 1 / predicted variance).
    pub prior_weight: f32,
    /// Smallest standard deviation (px) of the motion prior in the refinement: the motion
    /// model is only a model.
    pub prior_sigma_px: f32,
    /// Smallest spread of a bone's length prior (share of its length).
    pub length_sigma: f32,
    /// Where a bone's length prior is centred (0–1): 0 on its predicted length, 1 on its seed
    /// length times its body's current scale (the median over the body's bones of predicted
    /// over seed length); between, a geometric blend. 1 stops one bone creeping shorter or
    /// longer while the body as a whole may grow or shrink (nearer or further from the camera).
    pub length_anchor: f32,
    /// Smallest initial colour scale σ of the robust cost (levels per channel); it starts at
    /// twice the clip's measured noise if that is more, and adapts per bone to the residuals it
    /// sees, between 0.75× and 2× its start.
    pub colour_sigma: f32,
    /// Weight of the seed appearance (anchor) in a bone's template; the rest is its running one.
    pub anchor_weight: f32,
    /// Blend rate of the running appearance on confident frames.
    pub update_rate: f32,
    /// Half-width of a bone's strip, as a share of the smaller side of its child's rectangle.
    pub bone_half_width: f32,
    /// How far a bone's strip reaches past a leaf joint (the hand past the wrist, the foot past
    /// the ankle), as a share of half that joint's rectangle.
    pub end_reach: f32,
    /// How far a bone's strip reaches past a root, and past any other joint, as a share of the
    /// limb's half-width plus `edge_margin_px` (so that it holds the limb's rounded end).
    pub root_reach: f32,
    pub joint_reach: f32,
    /// Margin (px) past a limb's edge that its strip holds.
    pub edge_margin_px: f32,
    /// Colour distance (levels, RGB) within which a seed pixel shared by two bones' strips is
    /// taken for the other bone's (see `Strip::doubt_foreign`); 0 turns this off.
    pub foreign_tolerance: f32,
    /// How a limb's width follows its length, ×(L₀/L)^γ (docs/method.md eq. 4): 0 keeps it,
    /// 0.5 is a cartoon squash-and-stretch, 1 keeps the area in the image. Default 0.5: more
    /// accurate than 0 on the synthetic clips, no worse on real footage (docs/NOTES.md,
    /// "Parameter sweeps").
    pub width_exponent: f32,
    /// Most samples per bone.
    pub max_samples: usize,
    /// Most samples per bone in the coarse search.
    pub coarse_samples: usize,
    /// Smallest side (px) the joint rectangles keep on the coarsest pyramid level matched on:
    /// with 21-px rectangles that is the quarter-resolution level, with 15-px ones the half.
    pub coarse_box_px: f32,
    /// Gauss–Newton iterations of the refinement, per pyramid level.
    pub iterations: usize,
    /// Finest pyramid level the refinement goes down to (0: full resolution).
    pub finest_level: usize,
    /// Large frames are tracked halved (2×2 averages), up to twice, as long as the median seed
    /// rectangle keeps its smaller side at least this many px (0: always full resolution);
    /// every px parameter here is then in the halved frame's pixels (pyramid levels,
    /// `judge_level` and `finest_level`, still count from the frame). 20 keeps the synth clips
    /// at 640×360 (21-px rectangles) and the flies (15 px) at full resolution and tracks
    /// 1280×720 (43 px) at 640×360 (see [`super::scale`]).
    pub work_box_px: f32,
    /// Measurement standard deviation of a cleanly seen joint (px).
    pub meas_sigma_px: f32,
    /// Prior speed uncertainty of a root at the seed frame (px/frame).
    pub speed_sigma: f32,
    /// Prior turn-rate uncertainty of a bone at the seed frame (rad/frame).
    pub turn_sigma: f32,
    /// Random jerk of a root's motion model (px/frame³).
    pub jerk_sigma: f32,
    /// Random angular jerk of a bone's motion model (rad/frame³).
    pub turn_jerk_sigma: f32,
    /// Random jerk of a bone's log length (per frame³).
    pub stretch_jerk_sigma: f32,
    /// A joint is seen when at least this share of the samples near it (of any of its bones)
    /// fit; below, it is hidden (`occluded`).
    pub seen_share: f32,
    /// A seen joint is `ok` from this share on, when its body's joints also fit this share on
    /// average (docs/method.md §2.5); below, `low`.
    pub ok_share: f32,
    /// Pyramid level (0: full resolution) on which bones are judged seen or hidden: a coarser
    /// level averages out sensor noise and compression artefacts.
    pub judge_level: usize,
    /// A hidden bone found again around its parent is taken when its samples fit at least this
    /// share as well as they do on frames where the bone is seen (overall and at its child end).
    pub reacquire_share: f32,
    /// A hidden joint is looked for every this many frames (hidden joints take turns).
    pub reacquire_every: u32,
    /// A seen joint whose bone length differs from the predicted one by more than this share is
    /// `low`.
    pub bone_tolerance: f32,
    /// `true`: a root joint's angle turns with the bone to its first child; `false`: it keeps
    /// its seed orientation.
    pub rotate_roots: bool,
    /// Longest hidden stretch (frames) filled afterwards by interpolating the bone between the
    /// frames on either side (0: no filling; frames are held back that long).
    pub fill_gaps_max: u32,
    /// Frames in a row hidden before the status turns from `occluded` to `lost`.
    pub lost_after_frames: u32,
    /// Frames in a row a root is hidden before its whole body is looked for over the whole
    /// frame (0: never), and then every this many frames while it stays hidden.
    pub redetect_after: u32,
    pub redetect_every: u32,
    /// A body found again over the whole frame is taken when its root's evidence (share of
    /// fitting samples near it) is at least this. After a turn the far and near limbs trade
    /// places, so a body found where it is fits only 0.2–0.3 around the root; a higher share
    /// leaves a turned body lost (docs/NOTES.md, "Parameter sweeps").
    pub redetect_share: f32,
    /// Whether a pass run toward a key of every joint (a corrected segment file, or such a key;
    /// forward or backward) still looks for a lost body over the whole frame. `false` resumes a
    /// keyed run faster where bodies are often lost (the dance keyed every 50 frames 1.6× as
    /// fast, scoring the same), but a character that turns round between two keys is found
    /// again less often (synth `long` corrected 0.4 points lower).
    pub redetect_toward_keys: bool,
    /// The learned human pose cue (docs/method.md §2.8): `auto` runs it for a skeleton with a
    /// person's joint names whose seeds the network agrees with on the seed frame, `on` for any
    /// skeleton with a person's joint names, `off` never.
    pub pose: PoseMode,
}

/// When the pose cue runs (see [`TrackParams::pose`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PoseMode {
    #[default]
    Auto,
    On,
    Off,
}

/// The defaults, chosen on many synthetic clips at once (`scripts/accuracy`, seeds 1–30 of the
/// five short scenarios) rather than on one, and checked on the real clips (docs/benchmarks.md,
/// "Accuracy").
impl Default for TrackParams {
    fn default() -> Self {
        TrackParams {
            search_min_px: 6.0,
            search_max_px: 64.0,
            search_sigmas: 3.0,
            search_step_px: 2.0,
            search_max_steps: super::search::MAX_STEPS,
            move_evidence: 0.03,
            search_skip_cost: 0.05,
            angle_min_deg: 20.0,
            angle_max_deg: 60.0,
            stretch_min: 0.08,
            stretch_max: 0.35,
            geo_weight: 0.05,
            colour_weight: 100.0,
            prior_weight: 1.0,
            prior_sigma_px: 3.0,
            length_sigma: 0.15,
            length_anchor: 1.0,
            colour_sigma: 10.0,
            anchor_weight: 0.3,
            update_rate: 0.2,
            bone_half_width: 0.5,
            end_reach: 1.0,
            root_reach: 1.0,
            joint_reach: 1.0,
            edge_margin_px: 2.0,
            width_exponent: 0.5,
            foreign_tolerance: 20.0,
            max_samples: 256,
            coarse_samples: 48,
            coarse_box_px: 5.0,
            iterations: 4,
            finest_level: 0,
            work_box_px: 20.0,
            meas_sigma_px: 1.0,
            speed_sigma: 10.0,
            turn_sigma: 0.15,
            jerk_sigma: 2.0,
            turn_jerk_sigma: 0.03,
            stretch_jerk_sigma: 0.01,
            seen_share: 0.3,
            ok_share: 0.6,
            judge_level: 1,
            reacquire_share: 0.65,
            reacquire_every: 2,
            bone_tolerance: 0.3,
            rotate_roots: false,
            fill_gaps_max: 120,
            lost_after_frames: 30,
            redetect_after: 8,
            redetect_every: 4,
            redetect_share: 0.2,
            redetect_toward_keys: true,
            pose: PoseMode::Auto,
        }
    }
}
