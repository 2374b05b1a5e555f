//! `mocap2d review RUN`: writes `RUN/review/` — `overlay.mp4` (the clip with the tracked
//! rectangles, bones, names and statuses), `confidence.png` (score per joint over time) and
//! `segments.png` (each segment's first frame) — in one pass over the clip.

use crate::decode;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::review::data::RunData;
use crate::review::{draw, plot, sheet};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Folder of a run that `review` writes.
pub const REVIEW_DIR: &str = "review";

/// What `review` wrote.
#[derive(Debug, Clone)]
pub struct ReviewSummary {
    pub dir: PathBuf,
    /// Frames in overlay.mp4 (all frames of the clip).
    pub frames: u64,
    /// Segment files found (0: the sheet shows every 150th frame instead).
    pub segments: usize,
    pub tiles: usize,
    /// The contact sheet's header, which says what it shows.
    pub sheet_note: String,
}

/// `mocap2d review RUN [--clip CLIP]`: reads the run (and its clip: `clip`, else where run.toml
/// says), then writes the three review files atomically. The clip must have the run's frame size.
pub fn review(run: &Path, clip: Option<&Path>, progress: &dyn Progress) -> Result<ReviewSummary> {
    let data = RunData::read(run)?;
    let clip = data.clip(clip)?;
    let source = decode::open(&clip, Some(data.manifest.fps))?;
    let info = source.info().clone();
    if (info.width, info.height) != (data.manifest.width, data.manifest.height) {
        return Err(Error::Clip {
            path: clip,
            msg: format!(
                "is {}x{} but the run was tracked on {}x{} frames; give the run's clip with --clip",
                info.width, info.height, data.manifest.width, data.manifest.height
            ),
        });
    }
    let dir = run.join(REVIEW_DIR);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;

    let plot = plot::confidence(&data);
    crate::atomic::write(&dir.join("confidence.png"), &draw::png_bytes(&plot))?;

    let (specs, note) = sheet::plan(&data);
    let mut wanted: BTreeMap<u64, Vec<usize>> = BTreeMap::new();
    for (i, s) in specs.iter().enumerate() {
        wanted.entry(s.frame).or_default().push(i);
    }
    let mut tiles: Vec<Option<image::RgbImage>> = vec![None; specs.len()];
    progress.start("review", info.frame_count_hint);
    let frames = write_overlay(
        &dir.join("overlay.mp4"),
        source,
        &data,
        progress,
        |f, img| {
            for &i in wanted.get(&f).into_iter().flatten() {
                tiles[i] = Some(sheet::tile(img, &specs[i], &data));
            }
        },
    );
    progress.finish();
    let frames = frames?;
    let tiles: Vec<image::RgbImage> = tiles.into_iter().flatten().collect();
    let sheet = sheet::compose(&tiles, &note);
    crate::atomic::write(&dir.join("segments.png"), &draw::png_bytes(&sheet))?;
    Ok(ReviewSummary {
        dir,
        frames,
        segments: data.segments.len(),
        tiles: tiles.len(),
        sheet_note: note,
    })
}

/// Decodes every frame, hands the raw frame to `raw`, draws the overlay and encodes it.
#[cfg(feature = "ffmpeg")]
fn write_overlay(
    path: &Path,
    source: Box<dyn decode::FrameSource>,
    data: &RunData,
    progress: &dyn Progress,
    mut raw: impl FnMut(u64, &image::RgbImage),
) -> Result<u64> {
    let info = source.info().clone();
    let mut video =
        crate::encode::VideoWriter::create(path, info.width, info.height, info.fps, 23)?;
    let mut n = 0;
    for item in decode::spawn_reader(source, 4) {
        let (f, mut img) = item?;
        raw(f, &img);
        crate::review::overlay::draw_frame(&mut img, data, f);
        video.write(&img)?;
        n = f + 1;
        if !progress.advance(1) {
            return Err(Error::Interrupted);
        }
    }
    video.finish()?;
    Ok(n)
}

#[cfg(not(feature = "ffmpeg"))]
fn write_overlay(
    path: &Path,
    _source: Box<dyn decode::FrameSource>,
    _data: &RunData,
    _progress: &dyn Progress,
    _raw: impl FnMut(u64, &image::RgbImage),
) -> Result<u64> {
    Err(Error::Usage(format!(
        "{}: writing the overlay video needs the `ffmpeg` feature; rebuild with it",
        path.display()
    )))
}
