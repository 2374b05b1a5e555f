//! Spine timelines from per-frame values: the keys [`Keys`] asks for, with the Bézier curves of
//! [`super::curves`] between reduced keys (docs/method.md §7.1) or straight lines (§7).
//!
//! A Spine key's `curve` lists `cx1, cy1, cx2, cy2` for every value the timeline holds, in the
//! timeline's order (translate: x then y; scale: x then y), absolute time (s) and value. The
//! `scale` timelines here key x alone (y stays 1, Spine's default), so their curves carry y's
//! flat handles `cx1, 1, cx2, 1` too: spine-core reads 8 numbers for a two-value timeline.

use super::curves::{self, CurveKey};
use super::keys::{self, Keys};
use super::round;
use serde_json::{json, Map, Value};

/// One Spine timeline's layout.
pub(crate) struct Timeline<'a> {
    /// The fields written, one per component of the values.
    pub fields: &'a [&'a str],
    /// Values of the timeline not written (after the written ones): their defaults.
    pub unwritten: &'a [f64],
    /// Decimals of the written values and value handles.
    pub decimals: i32,
    /// Consecutive keys stay less than this apart in component 0.
    pub max_step: Option<f64>,
}

/// The keys of one timeline: `values[t]` on frame `t`, kept as `keys` says within `tol` (0: every
/// frame), each at `time(t)` seconds (as written).
pub(crate) fn timeline(
    values: &[Vec<f64>],
    keys: Keys,
    tol: f64,
    layout: &Timeline,
    time: &dyn Fn(usize) -> f64,
) -> Value {
    let kept: Vec<CurveKey> = if keys.curves() && tol > 0.0 {
        let times: Vec<f64> = (0..values.len()).map(time).collect();
        curves::reduce_spine(values, &times, tol, layout.max_step, layout.decimals)
    } else {
        keys::reduce(values, tol, layout.max_step)
            .into_iter()
            .map(|at| CurveKey { at, curve: None })
            .collect()
    };
    Value::Array(
        kept.into_iter()
            .map(|k| {
                let mut m = Map::new();
                m.insert("time".into(), json!(time(k.at)));
                for (c, f) in layout.fields.iter().enumerate() {
                    m.insert((*f).into(), json!(round(values[k.at][c], layout.decimals)));
                }
                if let Some(mut c) = k.curve {
                    let (cx1, cx2) = (c[0], c[2]);
                    for &d in layout.unwritten {
                        c.extend([cx1, d, cx2, d]);
                    }
                    m.insert("curve".into(), json!(c));
                }
                Value::Object(m)
            })
            .collect(),
    )
}

/// A `translate` timeline: `values[t]` = (x, y) px on frame `t`.
pub(crate) fn translate(values: &[Vec<f64>], keys: Keys, time: &dyn Fn(usize) -> f64) -> Value {
    let layout = Timeline {
        fields: &["x", "y"],
        unwritten: &[],
        decimals: 4,
        max_step: None,
    };
    timeline(values, keys, keys.tolerance(), &layout, time)
}

/// A `rotate` timeline: `values[t]` = (offset from setup, degrees) on frame `t`.
pub(crate) fn rotate(values: &[Vec<f64>], keys: Keys, time: &dyn Fn(usize) -> f64) -> Value {
    let layout = Timeline {
        fields: &["value"],
        unwritten: &[],
        decimals: 5,
        max_step: Some(180.0),
    };
    timeline(values, keys, keys.tolerance(), &layout, time)
}

/// A `scale` timeline keying x (`values[t]` = (scale x) on frame `t`) within `tol` (a scale).
pub(crate) fn scale_x(
    values: &[Vec<f64>],
    keys: Keys,
    tol: f64,
    time: &dyn Fn(usize) -> f64,
) -> Value {
    let layout = Timeline {
        fields: &["x"],
        unwritten: &[1.0],
        decimals: 6,
        max_step: None,
    };
    timeline(values, keys, tol, &layout, time)
}
