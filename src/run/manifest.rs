//! `run.toml`: the manifest that ties a run folder to its clip, seeds and parameters, so a later
//! command can check it works on the same inputs, and the checkpoint of a run in progress: how
//! many segments are tracked, and the hash of every segment file the tool wrote (a segment file
//! with another hash was edited by the user: a correction).

use crate::background::BackgroundSetting;
use crate::error::{Error, Result};
use crate::track::TrackParams;
use serde::{Deserialize, Serialize};
use std::io::Read;
use std::path::Path;

/// The manifest's file name in a run folder.
pub const RUN_TOML: &str = "run.toml";

/// Identity of a clip: where it was, how big, and a content hash (blake3, hex).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipId {
    pub path: String,
    pub bytes: u64,
    pub blake3: String,
}

/// Everything `run.toml` records.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    pub tool: String,
    pub version: String,
    pub clip: ClipId,
    pub width: u32,
    pub height: u32,
    pub fps: f64,
    /// Frames decoded from the clip (0 until the run is complete).
    pub frames: u64,
    pub seed_frame: u64,
    pub joints: usize,
    /// blake3 of the seed file as given.
    pub seeds_blake3: String,
    /// The background model (`[background]`; a string such as `median:25,rest` in run
    /// folders of earlier versions, still read).
    #[serde(deserialize_with = "crate::background::deserialize_either")]
    pub background: BackgroundSetting,
    pub background_threshold: u32,
    /// Frames per segment: a checkpoint and a file to correct (`segments/NNN.toml`) every this many frames
    /// from the seed frame on.
    pub segment_len: u64,
    /// blake3 of everything the tracks depend on (see [`Manifest::config_hash`]): `resume`
    /// carries on only with the same inputs.
    pub config_blake3: String,
    /// True once every segment is tracked and `tracks.csv`, `report.md` are written.
    pub complete: bool,
    /// Segments `0..tracked_segments` have their rows in `segments/NNN.csv` (the checkpoint).
    pub tracked_segments: u64,
    pub params: TrackParams,
    /// Set when the clip is damaged or cut short: where decoding stopped (frames before it were
    /// tracked). Absent for a clip that decoded to its end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decode_stop: Option<crate::decode::DecodeStop>,
    /// One record per segment file written so far, in order (`[[segment]]`).
    #[serde(default)]
    pub segment: Vec<SegmentRecord>,
}

/// What `run.toml` records about one segment (`[[segment]]`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SegmentRecord {
    /// The segment's first frame: the `frame` of `segments/NNN.toml`.
    pub first_frame: u64,
    /// blake3 (hex) of the versions of `segments/NNN.toml` the tool wrote and may still be on
    /// disk (more than one only for an instant, around a rewrite). A file whose hash is not
    /// here was edited by the user.
    pub written: Vec<String>,
    /// blake3 of `segments/NNN.toml` when the segment was last tracked from it ("" if never).
    pub tracked_from: String,
    /// blake3 of `segments/NNN.state`, what tracking had learnt when it reached this segment
    /// ("" for segment 0 and the clip's last frame).
    #[serde(default)]
    pub state: String,
}

impl Manifest {
    /// Reads and parses `run.toml` at `path`.
    pub fn read(path: &Path) -> Result<Manifest> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::RunFolder {
            path: path.to_owned(),
            msg: format!(
                "cannot read the run manifest ({e}); is this a folder written by `mocap2d track`?"
            ),
        })?;
        Manifest::parse(&text, path)
    }

    /// Parses the text of `run.toml` (`path` for messages only).
    pub fn parse(text: &str, path: &Path) -> Result<Manifest> {
        toml::from_str(text).map_err(|e| Error::RunFolder {
            path: path.to_owned(),
            msg: if e.message().contains("missing field") && !text.contains("segment_len") {
                "written by an older mocap2d, without segments; track the clip again".into()
            } else {
                format!("the run manifest is damaged or was edited: {}", e.message())
            },
        })
    }

    /// blake3 (hex) of what the tracks depend on: tool version, clip content, seed file,
    /// background model, segment length and every tracking parameter.
    pub fn config_hash(&self) -> String {
        let params = toml::to_string(&self.params).expect("parameters are plain TOML values");
        let text = format!(
            "version={}\nclip={}\nseeds={}\nbackground={}\nthreshold={}\nsegment_len={}\nseed_frame={}\n{params}",
            self.version,
            self.clip.blake3,
            self.seeds_blake3,
            self.background,
            self.background_threshold,
            self.segment_len,
            self.seed_frame,
        );
        blake3::hash(text.as_bytes()).to_hex().to_string()
    }

    /// Writes the manifest to `run_dir/run.toml` atomically.
    pub fn write(&self, run_dir: &Path) -> Result<()> {
        crate::atomic::write(&run_dir.join(RUN_TOML), self.to_toml().as_bytes())
    }

    /// Serialises to TOML text (deterministic).
    pub fn to_toml(&self) -> String {
        // Cannot fail: strings, floats, and integers below i64::MAX (counts and sizes); the fuzz
        // target `manifest` checks every manifest that parses also serialises.
        let body = toml::to_string(self).expect("manifest fields are all plain TOML values");
        format!(
            "# written by mocap2d; do not edit: later commands check the clip against it\n{body}"
        )
    }
}

/// Size and blake3 content hash of a clip: a file's bytes, or for a folder of frames, the
/// sorted file names and their bytes.
pub fn hash_clip(path: &Path) -> Result<(u64, String)> {
    let mut hasher = blake3::Hasher::new();
    let mut total = 0u64;
    let mut add_file = |p: &Path, hasher: &mut blake3::Hasher| -> Result<()> {
        let mut f = std::fs::File::open(p).map_err(|e| Error::io(p, e))?;
        let mut buf = vec![0u8; 1 << 20];
        loop {
            let n = f.read(&mut buf).map_err(|e| Error::io(p, e))?;
            if n == 0 {
                break;
            }
            total += n as u64;
            hasher.update(&buf[..n]);
        }
        Ok(())
    };
    if path.is_dir() {
        let mut names: Vec<_> = std::fs::read_dir(path)
            .map_err(|e| Error::io(path, e))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file())
            .collect();
        names.sort();
        for p in names {
            hasher.update(
                p.file_name()
                    .map(|n| n.as_encoded_bytes())
                    .unwrap_or_default(),
            );
            add_file(&p, &mut hasher)?;
        }
    } else {
        add_file(path, &mut hasher)?;
    }
    Ok((total, hasher.finalize().to_hex().to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Manifest {
        Manifest {
            tool: "mocap2d".into(),
            version: "0.1.0".into(),
            clip: ClipId {
                path: "c.mp4".into(),
                bytes: 10,
                blake3: "ab".into(),
            },
            width: 64,
            height: 48,
            fps: 30.0,
            frames: 12,
            seed_frame: 0,
            joints: 2,
            seeds_blake3: "cd".into(),
            background: BackgroundSetting::None,
            background_threshold: 0,
            segment_len: 5,
            config_blake3: String::new(),
            complete: true,
            tracked_segments: 3,
            params: TrackParams::default(),
            decode_stop: None,
            segment: vec![SegmentRecord {
                first_frame: 0,
                written: vec!["ef".into()],
                tracked_from: "ef".into(),
                state: String::new(),
            }],
        }
    }

    #[test]
    fn round_trips_and_the_config_hash_sees_the_parameters() {
        let dir = tempfile::tempdir().unwrap();
        let mut m = sample();
        m.config_blake3 = m.config_hash();
        m.write(dir.path()).unwrap();
        assert_eq!(Manifest::read(&dir.path().join(RUN_TOML)).unwrap(), m);
        let mut other = m.clone();
        other.params.search_max_px += 1.0;
        assert_ne!(other.config_hash(), m.config_hash());
        other = m.clone();
        other.tracked_segments = 1;
        assert_eq!(
            other.config_hash(),
            m.config_hash(),
            "progress is not config"
        );
    }

    #[test]
    fn the_background_string_of_earlier_versions_reads_with_the_same_config_hash() {
        let mut m = sample();
        m.background = BackgroundSetting::Median {
            samples: 25,
            rest: true,
        };
        m.config_blake3 = m.config_hash();
        let text = m.to_toml();
        assert!(text.contains("[background]\nkind = \"median\"\nsamples = 25\nrest = true\n"));
        // As mocap2d wrote it before: a string among the plain fields.
        let old = text
            .replace(
                "\n[background]\nkind = \"median\"\nsamples = 25\nrest = true\n",
                "",
            )
            .replace(
                "background_threshold = ",
                "background = \"median:25,rest\"\nbackground_threshold = ",
            );
        assert!(!old.contains("[background]"), "{old}");
        let read = Manifest::parse(&old, Path::new("run.toml")).unwrap();
        assert_eq!(read, m);
        assert_eq!(read.config_hash(), m.config_blake3);
        let e = Manifest::parse(
            &old.replace("median:25,rest", "median"),
            Path::new("run.toml"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("median:N,rest"), "{e}");
    }

    #[test]
    fn an_older_manifest_says_so() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(RUN_TOML);
        let text = sample().to_toml();
        let old: String = text
            .lines()
            .filter(|l| {
                ![
                    "segment_len",
                    "config_blake3",
                    "complete",
                    "tracked_segments",
                ]
                .iter()
                .any(|k| l.starts_with(k))
            })
            .map(|l| format!("{l}\n"))
            .collect();
        std::fs::write(&p, old).unwrap();
        let m = Manifest::read(&p).unwrap_err().to_string();
        assert!(
            m.contains("older mocap2d") && m.contains("track the clip again"),
            "{m}"
        );
    }
}
