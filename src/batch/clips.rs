//! Which clips a batch runs: the inputs expanded into a sorted clip list, the seed file of each
//! clip (a path template), and one worker's share of the list (`--shard i/n`).

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Video file extensions a folder is searched for (any case).
pub const VIDEO_EXTENSIONS: &[&str] = &["mp4", "mov", "mkv", "avi", "webm"];

/// Frame file extensions that make a folder an image-sequence clip (as [`crate::decode`] reads).
const FRAME_EXTENSIONS: &[&str] = &["png", "jpg", "jpeg"];

/// Expands the inputs into the sorted clip list, without repeats.
///
/// A file is a clip whatever its extension (one that does not decode fails as that clip's
/// error), and so is a path that does not exist (it fails the same way). A folder gives its
/// video files ([`VIDEO_EXTENSIONS`]) and its sub-folders of PNG/JPEG frames (image-sequence
/// clips), not looking deeper and passing over run folders (`*.mocap`) and hidden entries; a
/// folder holding only frames is itself an image-sequence clip. A folder with none of these is
/// an error ([`Error::Usage`]), as is an empty input list.
///
/// Clips are sorted by path, byte-wise, so every machine given the same arguments sees the same
/// list (see [`shard`]).
pub fn discover(inputs: &[PathBuf]) -> Result<Vec<PathBuf>> {
    if inputs.is_empty() {
        return Err(Error::Usage(
            "batch: no clips given; name video files, frame folders or folders of clips".into(),
        ));
    }
    let mut clips = Vec::new();
    for input in inputs {
        if input.is_dir() {
            let found = clips_in(input)?;
            if found.is_empty() {
                return Err(Error::Usage(format!(
                    "{}: no clips in this folder (video files .{}, or folders of PNG/JPEG \
                     frames); give the clips themselves or another folder",
                    input.display(),
                    VIDEO_EXTENSIONS.join(" .")
                )));
            }
            clips.extend(found);
        } else {
            clips.push(input.clone());
        }
    }
    clips.sort_by(|a, b| a.as_os_str().cmp(b.as_os_str()));
    clips.dedup();
    Ok(clips)
}

/// The clips directly in `dir` (see [`discover`]).
fn clips_in(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut videos = Vec::new();
    let mut frame_dirs = Vec::new();
    let mut has_frames = false;
    for path in list(dir)? {
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
        let name = name.unwrap_or_default();
        if name.starts_with('.') || name.ends_with(".mocap") {
            continue;
        }
        if path.is_dir() {
            if list(&path)?.iter().any(|p| has_ext(p, FRAME_EXTENSIONS)) {
                frame_dirs.push(path);
            }
        } else if has_ext(&path, VIDEO_EXTENSIONS) {
            videos.push(path);
        } else if has_ext(&path, FRAME_EXTENSIONS) {
            has_frames = true;
        }
    }
    if videos.is_empty() && frame_dirs.is_empty() && has_frames {
        return Ok(vec![dir.to_owned()]);
    }
    videos.extend(frame_dirs);
    Ok(videos)
}

/// The entries of a folder (unsorted).
fn list(dir: &Path) -> Result<Vec<PathBuf>> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    Ok(entries.filter_map(|e| e.ok().map(|e| e.path())).collect())
}

fn has_ext(path: &Path, exts: &[&str]) -> bool {
    path.is_file()
        && path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .is_some_and(|e| exts.contains(&e.as_str()))
}

/// A seed-file path template: `{dir}` (the clip's folder), `{stem}` (its name without the
/// extension) and `{name}` (its file name) are replaced per clip.
#[derive(Debug, Clone, PartialEq)]
pub struct SeedTemplate(String);

impl SeedTemplate {
    /// Checks the template's placeholders; an unknown `{...}` or an unclosed `{` is an
    /// [`Error::Usage`] naming it.
    pub fn parse(template: &str) -> Result<SeedTemplate> {
        let mut rest = template;
        while let Some(open) = rest.find('{') {
            let after = &rest[open + 1..];
            let close = after.find('}').ok_or_else(|| {
                Error::Usage(format!(
                    "--seeds {template:?}: a `{{` without `}}`; placeholders are {{dir}}, \
                     {{stem}} and {{name}}"
                ))
            })?;
            let key = &after[..close];
            if !["dir", "stem", "name"].contains(&key) {
                return Err(Error::Usage(format!(
                    "--seeds {template:?}: unknown placeholder {{{key}}}; use {{dir}} (the \
                     clip's folder), {{stem}} (its name without extension) or {{name}} (its \
                     file name)"
                )));
            }
            rest = &after[close + 1..];
        }
        Ok(SeedTemplate(template.to_string()))
    }

    /// The seed file of `clip`. `{dir}` of a clip given without a folder is `.`.
    pub fn for_clip(&self, clip: &Path) -> PathBuf {
        let dir = match clip.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_string_lossy().into_owned(),
            _ => ".".into(),
        };
        let stem = clip.file_stem().unwrap_or_default().to_string_lossy();
        let name = clip.file_name().unwrap_or_default().to_string_lossy();
        PathBuf::from(
            self.0
                .replace("{dir}", &dir)
                .replace("{stem}", &stem)
                .replace("{name}", &name),
        )
    }
}

/// One worker's share of a batch: shard `index` of `count`, both counted from 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// Parses `i/n` with `1 <= i <= n`; the error says what is wrong and gives an example.
    fn from_str(s: &str) -> std::result::Result<Shard, String> {
        let example = "e.g. --shard 3/16 (the third of 16 workers)";
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| format!("{s:?}: expected INDEX/COUNT, {example}"))?;
        let num = |v: &str, what: &str| {
            v.trim()
                .parse::<usize>()
                .map_err(|_| format!("{s:?}: the {what} {v:?} is not a whole number; {example}"))
        };
        let (index, count) = (num(i, "index")?, num(n, "count")?);
        if count == 0 {
            return Err(format!(
                "{s:?}: the shard count must be at least 1; {example}"
            ));
        }
        if index == 0 || index > count {
            return Err(format!(
                "{s:?}: the shard index counts from 1 to the count ({count}): use 1/{count} to \
                 {count}/{count} (a Kubernetes JOB_COMPLETION_INDEX counts from 0: add 1)"
            ));
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The clips of `shard`: clip `k` (0-based, in the sorted list) goes to shard `k mod n + 1`,
/// so the shards cover the list exactly once and each gets every n-th clip.
pub fn shard<T: Clone>(clips: &[T], shard: Shard) -> Vec<T> {
    clips
        .iter()
        .enumerate()
        .filter(|(k, _)| k % shard.count + 1 == shard.index)
        .map(|(_, c)| c.clone())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_cover_the_list_exactly_once() {
        let clips: Vec<usize> = (0..11).collect();
        for n in [1, 2, 3, 16] {
            let mut all: Vec<usize> = (1..=n)
                .flat_map(|i| shard(&clips, Shard { index: i, count: n }))
                .collect();
            all.sort();
            assert_eq!(all, clips, "{n} shards");
        }
        let one: Vec<usize> = shard(&clips, "1/2".parse().unwrap());
        let two: Vec<usize> = shard(&clips, "2/2".parse().unwrap());
        assert_eq!(one, vec![0, 2, 4, 6, 8, 10]);
        assert_eq!(two, vec![1, 3, 5, 7, 9]);
    }

    #[test]
    fn bad_shard_specs_say_why() {
        assert_eq!(
            "3/16".parse::<Shard>(),
            Ok(Shard {
                index: 3,
                count: 16
            })
        );
        for (spec, says) in [
            ("0/4", "counts from 1"),
            ("5/4", "1/4 to 4/4"),
            ("1/0", "at least 1"),
            ("3", "INDEX/COUNT"),
            ("a/4", "index \"a\""),
            ("1/-2", "count \"-2\""),
        ] {
            let e = spec.parse::<Shard>().unwrap_err();
            assert!(e.contains(says), "{spec}: {e}");
        }
    }

    #[test]
    fn seed_template_fills_placeholders() {
        let t = SeedTemplate::parse("{dir}/seeds/{stem}.toml").unwrap();
        assert_eq!(
            t.for_clip(Path::new("shots/a.b.mp4")),
            PathBuf::from("shots/seeds/a.b.toml")
        );
        assert_eq!(
            t.for_clip(Path::new("a.mp4")),
            PathBuf::from("./seeds/a.toml")
        );
        let t = SeedTemplate::parse("s/{name}.toml").unwrap();
        assert_eq!(
            t.for_clip(Path::new("x/frames")),
            PathBuf::from("s/frames.toml")
        );
        assert!(SeedTemplate::parse("{stme}.toml").is_err());
        assert!(SeedTemplate::parse("{stem.toml").is_err());
    }

    #[test]
    fn folders_give_videos_and_frame_folders_sorted() {
        let d = tempfile::tempdir().unwrap();
        let p = |r: &str| d.path().join(r);
        for f in ["b.MP4", "a.mov", "notes.txt", "c.webm"] {
            std::fs::write(p(f), b"x").unwrap();
        }
        for f in ["seq/f1.png", "old.mocap/x.png", "empty/readme"] {
            std::fs::create_dir_all(p(f).parent().unwrap()).unwrap();
            std::fs::write(p(f), b"x").unwrap();
        }
        let clips = discover(&[d.path().to_owned(), p("a.mov")]).unwrap();
        assert_eq!(clips, vec![p("a.mov"), p("b.MP4"), p("c.webm"), p("seq")]);
        // A folder of frames alone is one clip; a folder of nothing is an error.
        assert_eq!(discover(&[p("seq")]).unwrap(), vec![p("seq")]);
        assert!(matches!(discover(&[p("empty")]), Err(Error::Usage(_))));
    }
}
