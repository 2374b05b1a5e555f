//! Commands end to end on the bundled sample clip.

use super::*;
use crate::background::BackgroundChoice;
use crate::progress::NoProgress;
use std::path::{Path, PathBuf};

fn walk(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("clips/walk")
        .join(file)
}

/// A run folder of an earlier version, whose `run.toml` holds the background as a string
/// (`median:25,rest`, `plate:PATH`, `none`), resumes with the same model and tracks.
#[cfg(feature = "ffmpeg")]
#[test]
fn resume_reads_the_background_string_of_earlier_run_folders() {
    let dir = tempfile::tempdir().unwrap();
    let plate = walk("background.png");
    let choices = [
        BackgroundChoice::Median,
        BackgroundChoice::Plate(plate),
        BackgroundChoice::None,
    ];
    for (i, c) in choices.into_iter().enumerate() {
        let run = dir.path().join(format!("r{i}.mocap"));
        let opts = TrackOptions {
            out: Some(run.clone()),
            background: c.clone(),
            ..TrackOptions::new(walk("clip.mp4"), walk("joints.toml"))
        };
        track(&opts, &NoProgress).unwrap();
        let tracks = std::fs::read(run.join("tracks.csv")).unwrap();
        let toml_path = run.join("run.toml");
        let text = std::fs::read_to_string(&toml_path).unwrap();
        let m = crate::run::Manifest::parse(&text, &toml_path).unwrap();
        // As earlier versions wrote it: a string among the plain fields, no [background].
        let table = text.find("\n[background]\n").unwrap();
        let end = text[table + 1..]
            .find("\n\n")
            .map_or(text.len(), |e| table + 1 + e);
        let old = format!("{}{}", &text[..table], &text[end..]).replace(
            "background_threshold = ",
            &format!(
                "background = {:?}\nbackground_threshold = ",
                m.background.to_string()
            ),
        );
        assert!(!old.contains("[background]"), "{old}");
        std::fs::write(&toml_path, &old).unwrap();
        let resumed = resume(
            &ResumeOptions {
                run: run.clone(),
                segment: Some(0),
                ..ResumeOptions::default()
            },
            &NoProgress,
        )
        .unwrap();
        assert!(resumed.is_some(), "{c:?}");
        assert_eq!(
            std::fs::read(run.join("tracks.csv")).unwrap(),
            tracks,
            "{c:?}"
        );
        let again = crate::run::Manifest::read(&toml_path).unwrap();
        assert_eq!(again.background, m.background, "{c:?}");
        assert_eq!(again.config_blake3, m.config_blake3, "{c:?}");
    }
}

/// Parameters are validated on every path: a library caller's `track` (before anything is
/// written) and `resume` of a run whose `run.toml` holds a value out of range.
#[cfg(feature = "ffmpeg")]
#[test]
fn out_of_range_parameters_are_refused_by_track_and_resume() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("r.mocap");
    let mut opts = TrackOptions {
        out: Some(run.clone()),
        ..TrackOptions::new(walk("clip.mp4"), walk("joints.toml"))
    };
    opts.params.work_box_px = -1.0;
    let e = track(&opts, &NoProgress).unwrap_err();
    assert!(
        e.is_user_error() && e.to_string().contains("work_box_px = -1"),
        "{e}"
    );
    assert!(!run.exists(), "nothing written");
    opts.params = Default::default();
    track(&opts, &NoProgress).unwrap();
    let toml_path = run.join("run.toml");
    let mut m = crate::run::Manifest::read(&toml_path).unwrap();
    m.params.work_box_px = f32::NAN;
    m.config_blake3 = m.config_hash();
    m.write(&run).unwrap();
    let e = resume(
        &ResumeOptions {
            run: run.clone(),
            segment: Some(0),
            ..ResumeOptions::default()
        },
        &NoProgress,
    )
    .unwrap_err();
    assert!(matches!(e, crate::Error::RunFolder { .. }), "{e}");
    assert!(e.to_string().contains("work_box_px = NaN"), "{e}");
}
