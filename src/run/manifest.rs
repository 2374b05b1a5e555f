//! `run.toml`: the manifest that ties a run folder to its clip, seeds and parameters, so a later
//! command can check it works on the same inputs.

use crate::error::{Error, Result};
use crate::track::TrackParams;
use serde::{Deserialize, Serialize};
use std::io::Read;
use std::path::Path;

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
    /// Frames decoded from the clip.
    pub frames: u64,
    pub seed_frame: u64,
    pub joints: usize,
    /// blake3 of the seed file as given.
    pub seeds_blake3: String,
    /// `median:N` (temporal median of N sampled frames), `plate:PATH`, or `none`.
    pub background: String,
    pub background_threshold: u32,
    pub params: TrackParams,
    /// Set when the clip is damaged or cut short: where decoding stopped (frames before it were
    /// tracked). Absent for a clip that decoded to its end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decode_stop: Option<crate::decode::DecodeStop>,
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
            msg: format!("the run manifest is damaged or was edited: {}", e.message()),
        })
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
