//! Decoded frames to RGB images: swscale, written straight into the image's own buffer when its
//! rows need no padding.

use super::*;

/// Converts decoded frames to RGB images of the clip's size.
pub(super) struct RgbConverter {
    width: u32,
    height: u32,
    scaler: Option<Scaler>,
    /// The (padded) RGB frame the scaler writes when it cannot write the image directly, made
    /// on first use and reused.
    rgb: Option<ff::frame::Video>,
    /// Where the images' buffers come from, when the consumer hands them back.
    pub(super) recycler: Option<Recycler>,
}

/// Row lengths (bytes) that are a multiple of this are written by swscale straight into the
/// image: whole SIMD blocks a row, so nothing is written past the row's end. Others (odd widths)
/// go through a padded frame and are copied out row by row.
const DIRECT_ROW_MULTIPLE: usize = 64;

/// Spare bytes allocated past the last row of an image swscale writes directly, never read.
const SLACK: usize = 64;

impl RgbConverter {
    pub(super) fn new(width: u32, height: u32) -> RgbConverter {
        RgbConverter {
            width,
            height,
            scaler: None,
            rgb: None,
            recycler: None,
        }
    }

    /// `frame` as an RGB image of the clip's size; the error says what could not be converted.
    pub(super) fn convert(
        &mut self,
        frame: &ff::frame::Video,
    ) -> std::result::Result<RgbImage, String> {
        self.convert_via(frame, true)
    }

    /// [`RgbConverter::convert`], straight into the image's buffer when `direct` (and its
    /// rows allow it), else through the padded frame and a copy. The pixels are the same.
    pub(super) fn convert_via(
        &mut self,
        frame: &ff::frame::Video,
        direct: bool,
    ) -> std::result::Result<RgbImage, String> {
        let (w, h) = (self.width, self.height);
        let src = (frame.format(), frame.width(), frame.height());
        let stale = self.scaler.as_ref().is_none_or(|s| {
            let i = s.0.input();
            (i.format, i.width, i.height) != src
        });
        if stale {
            // A stream can change size mid-clip; every frame still comes out at the first size.
            let ctx = scaling::Context::get(
                src.0,
                src.1,
                src.2,
                Pixel::RGB24,
                w,
                h,
                // Without ACCURATE_RND, same-size yuv420p → RGB takes swscale's SIMD fast path:
                // about 1.4 ms less a 720p frame (2.5 vs 3.8 s of CPU for 900 frames).
                scaling::Flags::BILINEAR,
            )
            .map_err(|e| {
                format!(
                    "cannot convert {:?} {}x{} to RGB ({e})",
                    src.0, src.1, src.2
                )
            })?;
            self.scaler = Some(Scaler(ctx));
        }
        // Cannot fail: a scaler was made just above when none matched.
        let scaler = self.scaler.as_mut().expect("scaler set above");
        let row = w as usize * 3;
        let len = row * h as usize;
        let mut out: Vec<u8> = match &self.recycler {
            Some(r) => r.take(len + SLACK),
            None => Vec::with_capacity(len + SLACK),
        };
        // swscale's SIMD stores want 16-byte aligned rows; the allocator gives that in practice.
        if direct
            && row.is_multiple_of(DIRECT_ROW_MULTIPLE)
            && (out.as_ptr() as usize).is_multiple_of(16)
        {
            let dst = [
                out.as_mut_ptr(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
            ];
            let dst_stride = [row as i32, 0, 0, 0];
            // SAFETY: the input frame matches the scaler's input (checked above); the output is
            // one packed plane of `h` rows of `row` bytes, inside `out`'s capacity.
            let rows = unsafe {
                ff::ffi::sws_scale(
                    scaler.0.as_mut_ptr(),
                    (*frame.as_ptr()).data.as_ptr() as *const *const u8,
                    (*frame.as_ptr()).linesize.as_ptr(),
                    0,
                    src.2 as i32,
                    dst.as_ptr(),
                    dst_stride.as_ptr(),
                )
            };
            if rows != h as i32 {
                return Err(format!(
                    "cannot convert the frame to RGB (swscale gave {rows} rows)"
                ));
            }
            // SAFETY: swscale wrote all `h` rows of `row` bytes, the first `len` bytes.
            unsafe { out.set_len(len) };
        } else {
            let rgb = self
                .rgb
                .get_or_insert_with(|| ff::frame::Video::new(Pixel::RGB24, w, h));
            scaler
                .0
                .run(frame, rgb)
                .map_err(|e| format!("cannot convert the frame to RGB ({e})"))?;
            // Rows are padded to the stride (e.g. at odd widths): copy only the pixels.
            let stride = rgb.stride(0);
            let data = rgb.data(0);
            for y in 0..h as usize {
                out.extend_from_slice(&data[y * stride..y * stride + row]);
            }
        }
        // Cannot fail: `out` holds exactly h rows of w*3 bytes.
        Ok(RgbImage::from_raw(w, h, out).expect("buffer is width*height*3"))
    }
}
