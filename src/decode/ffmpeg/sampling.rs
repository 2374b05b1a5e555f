//! Frames sampled across a clip for the background: by seeking to keyframes when there are
//! enough of them, else by one sequential pass that decodes only the reference frames and the
//! frames it takes.

use super::*;

impl FfmpegSource {
    /// The keyframe at or before each of `n` evenly spaced timestamps (the centres of `n` equal
    /// slices of the stream's duration), found by seeking and reading the first video packet
    /// there, without decoding. Returns one target (µs) per distinct keyframe, the first that
    /// lands on it, in clip order: seeking to it again lands on that keyframe. Empty when the file
    /// states no duration or cannot seek. A few milliseconds, however many targets share a
    /// keyframe, so a clip with few keyframes costs nothing to rule out.
    pub(super) fn keyframe_targets(&mut self, n: usize) -> Vec<i64> {
        let Some((start_us, duration_us)) = self.time_span_us() else {
            return Vec::new();
        };
        let mut seen = HashSet::new();
        let mut targets = Vec::new();
        let mut packet = ff::Packet::empty();
        'targets: for i in 0..n as i64 {
            let target = start_us + ((2 * i + 1) * duration_us) / (2 * n as i64);
            // The keyframe at or before the target.
            if self.input.seek(target, ..target).is_err() {
                break;
            }
            let landed = loop {
                match packet.read(&mut self.input) {
                    Ok(()) if packet.stream() == self.stream_index => {
                        break packet.pts().or(packet.dts());
                    }
                    Ok(()) | Err(ff::Error::InvalidData) => {}
                    Err(_) => continue 'targets,
                }
            };
            // Without a timestamp there is nothing to compare: keep it, as decoding would.
            if landed.is_none_or(|ts| seen.insert(ts)) {
                targets.push(target);
            }
        }
        targets
    }

    /// The first frame decoded after seeking to each of `targets` (µs), skipping a frame already
    /// taken (same timestamp). Stops early, with what it has, on a seek or decode error: this is
    /// only a sample, and the caller decides whether it is enough.
    pub(super) fn decode_at(&mut self, targets: &[i64]) -> Vec<RgbImage> {
        let mut seen = HashSet::new();
        let mut frames = Vec::new();
        for &target in targets {
            if self.input.seek(target, ..target).is_err() {
                break;
            }
            self.decoder.flush();
            self.eof_sent = false;
            match self.decode_next() {
                Ok(true) => {}
                Ok(false) => continue,
                Err(_) => break,
            }
            if let Some(ts) = self.decoded.timestamp() {
                if !seen.insert(ts) {
                    continue;
                }
            }
            match self.convert() {
                Ok(frame) => frames.push(frame),
                Err(_) => break,
            }
        }
        frames
    }

    /// One frame at the keyframe at or before each of `n` evenly spaced timestamps, distinct
    /// keyframes only, in clip order. Fewer frames (possibly none) when the file cannot seek or
    /// has few keyframes.
    #[cfg(test)]
    pub(super) fn sample_by_seeking(&mut self, n: usize) -> Vec<RgbImage> {
        let targets = self.keyframe_targets(n);
        self.decode_at(&targets)
    }

    /// The video stream's start and duration in microseconds, if the file states a duration.
    pub(super) fn time_span_us(&self) -> Option<(i64, i64)> {
        let stream = self.input.stream(self.stream_index)?;
        let tb = stream.time_base();
        let start = match stream.start_time() {
            NO_PTS => 0,
            t => t.rescale(tb, MICROSECONDS),
        };
        let duration = if stream.duration() > 0 {
            stream.duration().rescale(tb, MICROSECONDS)
        } else {
            self.input.duration()
        };
        (duration > 0).then_some((start, duration))
    }

    /// `n` frames spread over the clip from one sequential decode: those an evenly thinned
    /// subset of every frame gives ([`thinned_indices`]). The frames' display order comes from
    /// their timestamps, read by demuxing the file first, so the decoder skips every
    /// non-reference frame that is not wanted (FFmpeg's `skip_frame`: often a third of an H.264
    /// file's frames and more) and stops after the last one wanted. The frames it decodes come
    /// out as in a full decode, so the sample is the one a full decode gives. Each wanted frame is
    /// converted to RGB as it comes; the others are not.
    ///
    /// Frame `also`, when given and reached, is decoded and converted too and returned beside
    /// them. A file whose packets lack timestamps or repeat one, or that gives fewer than half
    /// the wanted frames, is decoded whole instead ([`FfmpegSource::sample_every_frame`]).
    pub(super) fn sample_sequentially(
        &mut self,
        n: usize,
        also: Option<u64>,
    ) -> Result<(Vec<RgbImage>, Option<RgbImage>)> {
        let Some(times) = display_times(&self.info.path, self.stream_index) else {
            return self.sample_every_frame(n, also);
        };
        let chosen = thinned_indices(times.len() as u64, n);
        // Each wanted timestamp and its place in the sample.
        let slots: HashMap<i64, usize> = chosen
            .iter()
            .enumerate()
            .map(|(slot, &i)| (times[i as usize], slot))
            .collect();
        let also_at = also.and_then(|k| times.get(k as usize).copied());
        let mut pending: HashSet<i64> = slots.keys().copied().collect();
        pending.extend(also_at);
        self.decode_only = Some(pending.clone());
        let mut frames: Vec<Option<RgbImage>> = vec![None; chosen.len()];
        let mut extra = None;
        // A clip damaged part-way is sampled from the frames before the damage (as `track`
        // tracks those); one that decodes no frame at all is an error.
        while !pending.is_empty()
            && match self.decode_next() {
                Ok(more) => more,
                Err(_) if self.frames_out > 0 => false,
                Err(e) => return Err(e),
            }
        {
            self.frames_out += 1;
            let Some(pts) = self.decoded.pts().filter(|t| pending.remove(t)) else {
                continue;
            };
            if Some(pts) == also_at {
                // A frame that will not convert is left to the caller's own decode.
                extra = self.to_rgb.convert(&self.decoded).ok();
            }
            if let Some(&slot) = slots.get(&pts) {
                frames[slot] = Some(self.convert()?);
            }
        }
        self.decode_only = None;
        let frames: Vec<RgbImage> = frames.into_iter().flatten().collect();
        if frames.len() * 2 < chosen.len() {
            // Most wanted frames never came out (frames stamped otherwise than their packets, or
            // damage early on): decode every frame from the start instead.
            return FfmpegSource::open(&self.info.path, None)?.sample_every_frame(n, also);
        }
        Ok((frames, extra))
    }

    /// [`FfmpegSource::sample_sequentially`] by decoding every frame, counted in the order they
    /// come out: for a file whose timestamps cannot order its frames. Keeps every `stride`-th
    /// frame, doubling `stride` (and dropping every other kept frame) whenever `2n` are held, so
    /// memory stays bounded whatever the clip's length. Kept frames are the decoder's own
    /// (reference counted, not copied); only the `n` chosen at the end are converted to RGB.
    pub(super) fn sample_every_frame(
        &mut self,
        n: usize,
        also: Option<u64>,
    ) -> Result<(Vec<RgbImage>, Option<RgbImage>)> {
        let mut extra = None;
        let mut kept: Vec<(u64, ff::frame::Video)> = Vec::new();
        let mut stride = 1u64;
        let mut index = 0u64;
        while match self.decode_next() {
            Ok(more) => more,
            Err(_) if !kept.is_empty() => false,
            Err(e) => return Err(e),
        } {
            if also == Some(index) {
                extra = self.to_rgb.convert(&self.decoded).ok();
            }
            if index.is_multiple_of(stride) {
                // Take the frame; the next `receive_frame` fills a fresh one.
                let frame = std::mem::replace(&mut self.decoded, ff::frame::Video::empty());
                kept.push((index, frame));
                if kept.len() >= 2 * n {
                    kept = kept.into_iter().step_by(2).collect();
                    stride *= 2;
                }
            }
            index += 1;
            self.frames_out += 1;
        }
        let mut frames = Vec::with_capacity(n);
        for i in spread_indices(kept.len(), n) {
            let (index, frame) = &kept[i];
            frames.push(self.to_rgb.convert(frame).map_err(|msg| Error::Decode {
                path: self.info.path.clone(),
                frame: *index,
                msg,
            })?);
        }
        Ok((frames, extra))
    }
}

/// The frames (display indices, increasing) an evenly thinned sequential pass over `total`
/// frames samples `n` of: every `stride`-th frame kept, `stride` doubled (every other kept frame
/// dropped) whenever `2n` are held, then `n` of those spread evenly ([`spread_indices`]). What
/// [`FfmpegSource::sample_every_frame`] keeps, computed from the count alone.
pub(super) fn thinned_indices(total: u64, n: usize) -> Vec<u64> {
    let mut kept = Vec::new();
    let mut stride = 1u64;
    for index in 0..total {
        if index.is_multiple_of(stride) {
            kept.push(index);
            if kept.len() >= 2 * n {
                kept = kept.into_iter().step_by(2).collect();
                stride *= 2;
            }
        }
    }
    spread_indices(kept.len(), n)
        .into_iter()
        .map(|i| kept[i])
        .collect()
}

/// The timestamps (pts) of every packet of stream `stream` of `path`, sorted: the display order
/// of its frames, by demuxing alone (no decoding). `None` when the file cannot be read, a
/// packet has no timestamp or two share one: the order is then unknown.
fn display_times(path: &Path, stream: usize) -> Option<Vec<i64>> {
    let mut input = ff::format::input(path).ok()?;
    let mut times = Vec::new();
    let mut packet = ff::Packet::empty();
    loop {
        match packet.read(&mut input) {
            Ok(()) if packet.stream() == stream => times.push(packet.pts()?),
            Ok(()) | Err(ff::Error::InvalidData) => {}
            Err(ff::Error::Eof) => break,
            Err(_) => return None,
        }
    }
    times.sort_unstable();
    times.windows(2).all(|w| w[0] < w[1]).then_some(times)
}
