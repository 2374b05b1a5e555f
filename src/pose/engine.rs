//! The engine that runs the pose networks, behind one small trait ([`Engine`]) so the rest of
//! the crate sees tensors in and out, never the engine. [`OrtEngine`] is ONNX Runtime, loaded
//! at run time from its shared library (docs/guide.md, "The pose cue").

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Which of the two networks to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Network {
    /// The person detector: 224×224 RGB in [-1, 1] → boxes (2254 × 12), scores (2254).
    Detector,
    /// The landmark network: 256×256 RGB in [0, 1] → points (39 × 5), person (1),
    /// segmentation (256×256), heatmap (64×64×39), world points (39 × 3).
    Landmarks,
}

impl Network {
    /// The model file's name under the models folder.
    pub fn file_name(self) -> &'static str {
        match self {
            Network::Detector => "pose_detection.onnx",
            Network::Landmarks => "pose_landmark_full.onnx",
        }
    }

    /// Side of the square input (px).
    pub fn side(self) -> usize {
        match self {
            Network::Detector => super::blazepose::DETECTOR_SIDE,
            Network::Landmarks => super::blazepose::LANDMARK_SIDE,
        }
    }
}

/// Runs a network on one image: `input` is HWC floats of side [`Network::side`]; the outputs
/// come back flattened, in the model's order.
pub trait Engine: Send {
    fn run(&mut self, network: Network, input: &[f32]) -> Result<Vec<Vec<f32>>>;
}

/// Where the ONNX models are: `MOCAP2D_MODELS` when set, else `models/` beside the binary or
/// two levels up (a cargo build in the repository), else the repository the binary was built
/// from.
pub fn models_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("MOCAP2D_MODELS") {
        return PathBuf::from(dir);
    }
    if let Ok(exe) = std::env::current_exe() {
        for up in [1usize, 3] {
            if let Some(dir) = exe.ancestors().nth(up).map(|d| d.join("models")) {
                if dir.join(Network::Landmarks.file_name()).is_file() {
                    return dir;
                }
            }
        }
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("models")
}

/// The ONNX Runtime library to load: `MOCAP2D_ONNXRUNTIME` (or ONNX Runtime's own
/// `ORT_DYLIB_PATH`) when set, else the copy `scripts/setup` installs.
pub fn library_path() -> PathBuf {
    for var in ["MOCAP2D_ONNXRUNTIME", "ORT_DYLIB_PATH"] {
        if let Some(p) = std::env::var_os(var) {
            return PathBuf::from(p);
        }
    }
    PathBuf::from(INSTALLED_LIBRARY)
}

/// Where `scripts/setup` puts ONNX Runtime's library (from the PyPI wheel).
pub const INSTALLED_LIBRARY: &str = "/usr/local/lib/mocap2d/libonnxruntime.so";

/// What to do when the engine or a model cannot be had.
const FIX: &str = "run `bash scripts/setup` (it installs ONNX Runtime), set MOCAP2D_ONNXRUNTIME \
                   to a libonnxruntime.so of version 1.20 or later, or track without the cue \
                   (`--pose off`)";

/// ONNX Runtime with both networks loaded, one thread each run (the tracker has the other core).
pub struct OrtEngine {
    detector: ort::session::Session,
    landmarks: ort::session::Session,
}

impl OrtEngine {
    /// Loads the library ([`library_path`]) and both models from `models` (see
    /// [`models_dir`]). A library that does not load, or a missing or unreadable model, is the
    /// user's to fix: [`Error::Usage`] naming the path and the fix.
    pub fn load(models: &Path) -> Result<OrtEngine> {
        let lib = library_path();
        let env = environment(&lib)?;
        let open = |network: Network| -> Result<ort::session::Session> {
            let path = models.join(network.file_name());
            let bytes = std::fs::read(&path).map_err(|e| {
                Error::Usage(format!(
                    "{}: cannot read the pose model ({e}); restore it with `git checkout -- \
                     models/` in the repository, set MOCAP2D_MODELS to the folder that has it, \
                     or track without the cue (`--pose off`)",
                    path.display()
                ))
            })?;
            let corrupt = |e: ort::Error| {
                Error::Usage(format!(
                    "{}: not a usable pose model ({e}); restore it with `git checkout -- \
                     models/` in the repository, or track without the cue (`--pose off`)",
                    path.display()
                ))
            };
            ort::session::Session::builder(&env)
                .map_err(corrupt)?
                .with_intra_threads(1)
                .map_err(|e| corrupt(e.into()))?
                .commit_from_memory(&bytes)
                .map_err(corrupt)
        };
        Ok(OrtEngine {
            detector: open(Network::Detector)?,
            landmarks: open(Network::Landmarks)?,
        })
    }
}

/// ONNX Runtime's environment, its library loaded once a process. A library that is not there
/// yet is looked for again at the next call (a server started before `scripts/setup` finds it
/// once installed); one that was found but failed to load stays failed, as the runtime keeps
/// its library for the life of the process.
fn environment(lib: &Path) -> Result<ort::environment::Environment> {
    static ENV: std::sync::Mutex<
        Option<std::result::Result<ort::environment::Environment, String>>,
    > = std::sync::Mutex::new(None);
    let mut env = ENV.lock().unwrap_or_else(|e| e.into_inner());
    let loaded = match &*env {
        Some(done) => done.clone(),
        None if !lib.is_file() => Err("no such file".to_string()),
        None => {
            let built = ort::init_from(lib)
                .map_err(|e| e.to_string())
                .and_then(|b| b.build().map_err(|e| e.to_string()));
            env.insert(built).clone()
        }
    };
    loaded.map_err(|e| {
        Error::Usage(format!(
            "{}: cannot load ONNX Runtime for the pose cue ({e}); {FIX}",
            lib.display()
        ))
    })
}

impl Engine for OrtEngine {
    fn run(&mut self, network: Network, input: &[f32]) -> Result<Vec<Vec<f32>>> {
        let side = network.side();
        let session = match network {
            Network::Detector => &mut self.detector,
            Network::Landmarks => &mut self.landmarks,
        };
        let failed = |e: ort::Error| Error::Engine(format!("the pose network failed: {e}"));
        let tensor = ort::value::Tensor::from_array(([1usize, side, side, 3], input.to_vec()))
            .map_err(failed)?;
        let outputs = session.run(ort::inputs![tensor]).map_err(failed)?;
        let mut out = Vec::with_capacity(outputs.len());
        for (_, value) in outputs.iter() {
            let (_, data) = value.try_extract_tensor::<f32>().map_err(failed)?;
            out.push(data.to_vec());
        }
        Ok(out)
    }
}
