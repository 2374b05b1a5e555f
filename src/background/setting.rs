//! The background model a run used, as `run.toml` records it: a typed `[background]` table
//! (`kind = "median"`, `"plate"`, `"none"` or `"moving-camera"`), read back as it was written. Run folders of
//! mocap2d before it hold a string (`median:N,rest`, `median:N`, `plate:PATH`, `none`), still
//! read; the string form is also what the manifest's config hash covers, so a run's hash is the
//! same in either form.

use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::{Deserialize, Serialize, Serializer};
use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

/// The background model of a run (`[background]` in `run.toml`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum BackgroundSetting {
    /// No background subtraction (`--no-background`).
    None,
    /// No background subtraction because the camera moves: a median was asked for, and the
    /// camera check found the clip's background shifting ([`super::camera`]).
    #[serde(rename = "moving-camera")]
    MovingCamera,
    /// A clean plate read from a file (`--background PLATE`).
    Plate {
        #[serde(serialize_with = "path_text")]
        path: PathBuf,
    },
    /// The temporal median of `samples` frames sampled across the clip; with `rest`, cleared of
    /// the subjects at rest on the seed frame (runs made before that have `rest = false`).
    /// (`samples` is a `u32` so that every setting that reads also writes as TOML.)
    Median { samples: u32, rest: bool },
}

/// A path as text (lossy for a path that is not UTF-8, as `run.toml` always held it).
fn path_text<S: Serializer>(p: &std::path::Path, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&p.display().to_string())
}

/// The string form: `none`, `plate:PATH`, `median:N` or `median:N,rest`.
impl fmt::Display for BackgroundSetting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BackgroundSetting::None => write!(f, "none"),
            BackgroundSetting::MovingCamera => write!(f, "moving-camera"),
            BackgroundSetting::Plate { path } => write!(f, "plate:{}", path.display()),
            BackgroundSetting::Median { samples, rest } => {
                write!(f, "median:{samples}{}", if *rest { ",rest" } else { "" })
            }
        }
    }
}

/// Parses the string form that run folders of earlier versions hold.
impl FromStr for BackgroundSetting {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "none" {
            return Ok(BackgroundSetting::None);
        }
        if s == "moving-camera" {
            return Ok(BackgroundSetting::MovingCamera);
        }
        if let Some(path) = s.strip_prefix("plate:") {
            return Ok(BackgroundSetting::Plate { path: path.into() });
        }
        if let Some(m) = s.strip_prefix("median:") {
            let (n, rest) = match m.strip_suffix(",rest") {
                Some(n) => (n, true),
                None => (m, false),
            };
            if let Ok(samples) = n.parse() {
                return Ok(BackgroundSetting::Median { samples, rest });
            }
        }
        Err(format!(
            "background = {s:?}: expected `none`, `plate:PATH`, `median:N` or `median:N,rest`"
        ))
    }
}

/// Reads either form: a `[background]` table, or the string of an earlier version.
pub(crate) fn deserialize_either<'de, D: Deserializer<'de>>(
    d: D,
) -> Result<BackgroundSetting, D::Error> {
    struct Either;
    impl<'de> Visitor<'de> for Either {
        type Value = BackgroundSetting;
        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str(
                "a [background] table with kind = \"median\", \"plate\", \"none\" or \
                 \"moving-camera\"",
            )
        }
        fn visit_str<E: de::Error>(self, s: &str) -> Result<BackgroundSetting, E> {
            s.parse().map_err(E::custom)
        }
        fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<BackgroundSetting, A::Error> {
            BackgroundSetting::deserialize(de::value::MapAccessDeserializer::new(map))
        }
    }
    d.deserialize_any(Either)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Holder {
        #[serde(deserialize_with = "deserialize_either")]
        background: BackgroundSetting,
    }

    #[test]
    fn the_table_round_trips_and_the_string_form_still_reads() {
        let all = [
            BackgroundSetting::None,
            BackgroundSetting::MovingCamera,
            BackgroundSetting::Plate {
                path: "clips/walk/background.png".into(),
            },
            BackgroundSetting::Median {
                samples: 25,
                rest: true,
            },
            BackgroundSetting::Median {
                samples: 7,
                rest: false,
            },
        ];
        for b in all {
            let h = Holder { background: b };
            let text = toml::to_string(&h).unwrap();
            assert!(text.contains("[background]\nkind = "), "{text}");
            assert_eq!(toml::from_str::<Holder>(&text).unwrap(), h);
            let old = format!("background = {:?}\n", h.background.to_string());
            assert_eq!(toml::from_str::<Holder>(&old).unwrap(), h, "{old}");
        }
        assert_eq!(
            BackgroundSetting::Median {
                samples: 25,
                rest: true
            }
            .to_string(),
            "median:25,rest"
        );
    }

    #[test]
    fn a_damaged_setting_says_what_is_expected() {
        let e = toml::from_str::<Holder>("background = \"median\"\n").unwrap_err();
        assert!(e.message().contains("median:N,rest"), "{e}");
        // Too many samples to write back as TOML: refused on reading.
        assert!(toml::from_str::<Holder>("background = \"median:99999999999\"\n").is_err());
        let e = toml::from_str::<Holder>("[background]\nkind = \"blur\"\n").unwrap_err();
        assert!(e.message().contains("blur"), "{e}");
        let e =
            toml::from_str::<Holder>("[background]\nkind = \"median\"\nsamples = 3\n").unwrap_err();
        assert!(e.message().contains("rest"), "{e}");
    }
}
