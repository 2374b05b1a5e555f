//! Flag parsing and the flags → options step.

use super::*;
use std::path::PathBuf;

#[test]
fn parses_track_flags() {
    let cli = Cli::try_parse_from([
        "mocap2d", "track", "a.mp4", "--seeds", "j.toml", "--fps", "24",
    ])
    .unwrap();
    match cli.command {
        Command::Track(a) => {
            assert_eq!(a.clip, PathBuf::from("a.mp4"));
            assert_eq!(a.seed_source(), (PathBuf::from("j.toml"), None));
            assert_eq!(a.fps, Some(24.0));
        }
        _ => panic!("not track"),
    }
}

#[test]
fn parses_retarget_and_render_flags() {
    let cli = Cli::try_parse_from([
        "mocap2d",
        "retarget",
        "r.mocap",
        "--target",
        "c.toml",
        "--cartoon",
        "1.5",
        "--smooth",
        "median:5",
    ])
    .unwrap();
    let Command::Retarget(a) = cli.command else {
        panic!("not retarget")
    };
    let o = a.options();
    assert_eq!(o.cartoon.unwrap().strength, 1.5);
    assert_eq!(o.cartoon.unwrap().sigma_frames, 4.0);
    assert!(Cli::try_parse_from([
        "mocap2d",
        "retarget",
        "r",
        "--target",
        "c",
        "--cartoon-sigma",
        "2"
    ])
    .is_err());
    assert!(Cli::try_parse_from(["mocap2d", "render", "r", "--target", "c"]).is_err());
    assert!(Cli::try_parse_from([
        "mocap2d",
        "render",
        "r",
        "--target",
        "c",
        "--frames-dir",
        "f"
    ])
    .is_ok());
}

#[test]
fn parses_segment_flags() {
    let cli = Cli::try_parse_from([
        "mocap2d",
        "track",
        "a.mp4",
        "--seeds",
        "j.toml",
        "--segment-len",
        "40",
    ])
    .unwrap();
    let Command::Track(a) = cli.command else {
        panic!("not track")
    };
    assert_eq!(a.segment_len, 40);
    assert!(Cli::try_parse_from([
        "mocap2d",
        "track",
        "a.mp4",
        "--seeds",
        "j.toml",
        "--segment-len",
        "0"
    ])
    .is_err());
    let cli = Cli::try_parse_from(["mocap2d", "resume", "r.mocap", "--segment", "3"]).unwrap();
    let Command::Resume(a) = cli.command else {
        panic!("not resume")
    };
    assert_eq!(a.segment, Some(3));
}

#[test]
fn size_must_be_even() {
    assert_eq!(parse_size("640x360"), Ok((640, 360)));
    assert!(parse_size("641x360").is_err());
    assert!(parse_size("640").is_err());
}

#[test]
fn flags_become_options_in_one_step() {
    let cli = Cli::try_parse_from([
        "mocap2d",
        "track",
        "a.mp4",
        "--seeds",
        "j.toml",
        "--no-background",
        "--replace",
    ])
    .unwrap();
    let Command::Track(a) = cli.command else {
        panic!("not track")
    };
    let (o, other) = a.options().unwrap();
    assert_eq!(o.background, mocap2d::background::BackgroundChoice::None);
    assert_eq!(other, mocap2d::app::OtherClip::Replace);
    assert_eq!(o.params, mocap2d::track::TrackParams::default());
    let cli = Cli::try_parse_from([
        "mocap2d",
        "track",
        "a.mp4",
        "--seeds",
        "j.toml",
        "--background",
        "p.png",
    ])
    .unwrap();
    let Command::Track(a) = cli.command else {
        panic!("not track")
    };
    let (o, other) = a.options().unwrap();
    assert_eq!(
        o.background,
        mocap2d::background::BackgroundChoice::Plate("p.png".into())
    );
    assert_eq!(other, mocap2d::app::OtherClip::Refuse);
}
