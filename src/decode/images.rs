//! A folder of numbered PNG/JPEG frames, read in natural order (`frame2` before `frame10`).

use super::{spread_indices, ClipInfo, FrameSource};
use crate::error::{Error, Result};
use image::RgbImage;
use std::cmp::Ordering;
use std::path::{Path, PathBuf};

/// Frames read one file at a time from a folder of PNG/JPEG images of one size.
#[derive(Debug)]
pub struct ImageFolderSource {
    info: ClipInfo,
    files: Vec<PathBuf>,
    next: usize,
}

impl ImageFolderSource {
    /// Lists the PNG/JPEG files in `dir` (extensions `.png`, `.jpg`, `.jpeg`, any case; hidden
    /// files skipped) in natural order and checks that they all have the first one's size, reading
    /// only their headers. `fps` is frames per second.
    ///
    /// Errors: [`Error::Clip`] if the folder cannot be listed, holds no frames, or a frame is
    /// unreadable or of another size (naming that file).
    pub fn open(dir: &Path, fps: f64) -> Result<Self> {
        let files = list_frames(dir)?;
        let (width, height) = dimensions(&files[0])?;
        super::check_frame_size(&files[0], width, height)?;
        for file in &files[1..] {
            let (w, h) = dimensions(file)?;
            if (w, h) != (width, height) {
                return Err(Error::Clip {
                    path: file.clone(),
                    msg: format!(
                        "frame is {w}x{h} but the first frame ({}) is {width}x{height}; all \
                         frames of a clip must be the same size",
                        files[0].display()
                    ),
                });
            }
        }
        let info = ClipInfo {
            path: dir.to_owned(),
            width,
            height,
            fps,
            frame_count_hint: Some(files.len() as u64),
            stated_frames: Some(files.len() as u64),
        };
        Ok(ImageFolderSource {
            info,
            files,
            next: 0,
        })
    }

    /// The frame files, in the order they are yielded.
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }
}

impl FrameSource for ImageFolderSource {
    fn info(&self) -> &ClipInfo {
        &self.info
    }

    fn next_frame(&mut self) -> Result<Option<RgbImage>> {
        let Some(file) = self.files.get(self.next) else {
            return Ok(None);
        };
        let frame = read_frame(file, self.next as u64, (self.info.width, self.info.height))?;
        self.next += 1;
        Ok(Some(frame))
    }
}

/// `n` frames of the folder spread evenly (all of them if it has fewer), in order. A damaged
/// frame is left out of the sample (as `track` leaves out the frames from it on); the first
/// error is returned only if no chosen frame could be read.
pub(super) fn sample(dir: &Path, n: usize) -> Result<Vec<RgbImage>> {
    let source = ImageFolderSource::open(dir, super::DEFAULT_IMAGE_FPS)?;
    let size = (source.info.width, source.info.height);
    let mut frames = Vec::new();
    let mut first_error = None;
    for i in spread_indices(source.files.len(), n) {
        match read_frame(&source.files[i], i as u64, size) {
            Ok(f) => frames.push(f),
            Err(e @ Error::Decode { .. }) => {
                first_error.get_or_insert(e);
            }
            Err(e) => return Err(e),
        }
    }
    match first_error {
        Some(e) if frames.is_empty() => Err(e),
        _ => Ok(frames),
    }
}

/// Reads frame `index` from `file` as RGB, checking it is `size` (width, height) px.
fn read_frame(file: &Path, index: u64, size: (u32, u32)) -> Result<RgbImage> {
    let img = image::open(file)
        .map_err(|e| Error::Decode {
            path: file.to_owned(),
            frame: index,
            msg: format!(
                "cannot read the image {}: {e}",
                file.file_name().unwrap_or_default().to_string_lossy()
            ),
        })?
        .into_rgb8();
    if img.dimensions() != size {
        return Err(Error::Clip {
            path: file.to_owned(),
            msg: format!(
                "frame is {}x{} but the clip is {}x{}; all frames of a clip must be the same size",
                img.width(),
                img.height(),
                size.0,
                size.1
            ),
        });
    }
    Ok(img)
}

/// A frame file's size in px from its header, or [`Error::Clip`] naming it.
fn dimensions(file: &Path) -> Result<(u32, u32)> {
    image::image_dimensions(file).map_err(|e| Error::Clip {
        path: file.to_owned(),
        msg: format!("not a readable PNG/JPEG image: {e}"),
    })
}

/// The PNG/JPEG files in `dir`, naturally sorted by name; [`Error::Clip`] if there are none.
fn list_frames(dir: &Path) -> Result<Vec<PathBuf>> {
    let cannot_list = |e: std::io::Error| Error::Clip {
        path: dir.to_owned(),
        msg: format!("cannot list the folder: {e}"),
    };
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(cannot_list)? {
        let path = entry.map_err(cannot_list)?.path();
        let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
            continue;
        };
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        let is_image = ["png", "jpg", "jpeg"]
            .iter()
            .any(|x| ext.eq_ignore_ascii_case(x));
        if is_image && !name.starts_with('.') && path.is_file() {
            files.push(path);
        }
    }
    if files.is_empty() {
        return Err(Error::Clip {
            path: dir.to_owned(),
            msg: "no PNG or JPEG frames in this folder; expected numbered files such as \
                  frame0001.png"
                .into(),
        });
    }
    files.sort_by(|a, b| natural_cmp(&file_name(a), &file_name(b)));
    Ok(files)
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Natural order of names: runs of ASCII digits compare as numbers (`frame2` < `frame10`), the
/// rest character by character. Names equal under that rule (`f01`, `f1`) fall back to plain
/// string order, so the order is total.
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (x, y) = (a.as_bytes(), b.as_bytes());
    let (mut i, mut j) = (0, 0);
    while i < x.len() && j < y.len() {
        if x[i].is_ascii_digit() && y[j].is_ascii_digit() {
            let (si, sj) = (i, j);
            while i < x.len() && x[i].is_ascii_digit() {
                i += 1;
            }
            while j < y.len() && y[j].is_ascii_digit() {
                j += 1;
            }
            let trim = |s: &[u8]| {
                let start = s.iter().position(|&c| c != b'0').unwrap_or(s.len());
                s[start..].to_vec()
            };
            let (nx, ny) = (trim(&x[si..i]), trim(&y[sj..j]));
            // Without leading zeros, a longer digit run is a bigger number.
            let ord = nx.len().cmp(&ny.len()).then_with(|| nx.cmp(&ny));
            if ord != Ordering::Equal {
                return ord;
            }
        } else {
            // Compare whole characters so multi-byte UTF-8 stays in code-point order.
            let cx = a[i..].chars().next().unwrap_or_default();
            let cy = b[j..].chars().next().unwrap_or_default();
            if cx != cy {
                return cx.cmp(&cy);
            }
            i += cx.len_utf8();
            j += cy.len_utf8();
        }
    }
    (x.len() - i).cmp(&(y.len() - j)).then_with(|| a.cmp(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write_png(dir: &Path, name: &str, w: u32, h: u32, value: u8) {
        RgbImage::from_pixel(w, h, image::Rgb([value, 255 - value, 7]))
            .save(dir.join(name))
            .unwrap();
    }

    #[test]
    fn natural_order_compares_numbers() {
        let mut names = vec![
            "frame10.png",
            "frame2.png",
            "frame1.png",
            "frame002.png",
            "a.png",
        ];
        names.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(
            names,
            [
                "a.png",
                "frame1.png",
                "frame002.png",
                "frame2.png",
                "frame10.png"
            ]
        );
        assert_eq!(
            natural_cmp("x99999999999999999999999", "x100000000000000000000000"),
            Ordering::Less
        );
        assert_eq!(natural_cmp("f1", "f1a"), Ordering::Less);
        assert_eq!(natural_cmp("é2", "é10"), Ordering::Less);
    }

    #[test]
    fn folder_yields_frames_in_natural_order() {
        let dir = tempfile::tempdir().unwrap();
        for i in [10u8, 2, 1, 0] {
            write_png(dir.path(), &format!("f{i}.png"), 6, 4, i * 20);
        }
        std::fs::write(dir.path().join("notes.txt"), "not a frame").unwrap();
        let mut s = ImageFolderSource::open(dir.path(), 24.0).unwrap();
        assert_eq!(s.info().frame_count_hint, Some(4));
        assert_eq!(
            (s.info().width, s.info().height, s.info().fps),
            (6, 4, 24.0)
        );
        let mut values = Vec::new();
        while let Some(f) = s.next_frame().unwrap() {
            values.push(f.get_pixel(5, 3)[0]);
        }
        assert_eq!(values, [0, 20, 40, 200]);
    }

    #[test]
    fn empty_folder_is_a_clip_error() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("readme.txt"), "x").unwrap();
        let err = ImageFolderSource::open(dir.path(), 30.0).unwrap_err();
        assert!(matches!(err, Error::Clip { .. }), "{err}");
        assert!(err.to_string().contains("no PNG or JPEG frames"), "{err}");
    }

    #[test]
    fn mixed_sizes_name_the_odd_file() {
        let dir = tempfile::tempdir().unwrap();
        write_png(dir.path(), "f1.png", 6, 4, 0);
        write_png(dir.path(), "f2.png", 6, 4, 0);
        write_png(dir.path(), "f3.png", 8, 4, 0);
        let err = ImageFolderSource::open(dir.path(), 30.0).unwrap_err();
        match &err {
            Error::Clip { path, msg } => {
                assert!(path.ends_with("f3.png"), "{err}");
                assert!(msg.contains("8x4") && msg.contains("6x4"), "{err}");
            }
            _ => panic!("{err}"),
        }
    }

    #[test]
    fn sample_reads_spread_files() {
        let dir = tempfile::tempdir().unwrap();
        for i in 0..10u8 {
            write_png(dir.path(), &format!("f{i}.png"), 4, 4, i);
        }
        let got: Vec<_> = sample(dir.path(), 5)
            .unwrap()
            .iter()
            .map(|f| f.get_pixel(0, 0)[0])
            .collect();
        assert_eq!(got, [1, 3, 5, 7, 9]);
        assert_eq!(sample(dir.path(), 50).unwrap().len(), 10);
    }
}
