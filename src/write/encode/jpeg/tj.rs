//! The one place that calls TurboJPEG's C API directly: the `turbojpeg`
//! crate's `Compressor` does not expose the restart interval. Declared with
//! `#[allow(unsafe_code)]` in `jpeg/mod.rs`; every `unsafe` has its SAFETY note.

use std::ffi::{CStr, c_int};

use turbojpeg::raw;

use super::JpegError;

/// A TurboJPEG compressor set up as [`super::compress`] describes.
pub struct Compressor {
    handle: raw::tjhandle,
}

impl Drop for Compressor {
    fn drop(&mut self) {
        // SAFETY: `handle` came from `tj3Init`, is not null, and is destroyed once.
        unsafe { raw::tj3Destroy(self.handle) };
    }
}

impl Compressor {
    /// A restart marker every `blocks` MCUs; `grey`: one channel, the
    /// pixels' luma (for R = G = B pixels the grey itself, as the colour
    /// JPEG's Y plane holds it).
    pub fn new(quality: u8, blocks: u32, grey: bool) -> Result<Self, JpegError> {
        // SAFETY: plain constructor; a null result is handled below.
        let handle = unsafe { raw::tj3Init(raw::TJINIT_TJINIT_COMPRESS as c_int) };
        if handle.is_null() {
            return Err(JpegError::Library(
                "libjpeg-turbo could not make a compressor".into(),
            ));
        }
        let c = Self { handle };
        let subsamp = if grey {
            raw::TJSAMP_TJSAMP_GRAY
        } else if super::grid::subsampled(quality) {
            raw::TJSAMP_TJSAMP_420
        } else {
            raw::TJSAMP_TJSAMP_444
        };
        c.set(raw::TJPARAM_TJPARAM_QUALITY, i32::from(quality))?;
        c.set(raw::TJPARAM_TJPARAM_SUBSAMP, subsamp)?;
        let blocks = i32::try_from(blocks)?;
        c.set(raw::TJPARAM_TJPARAM_RESTARTBLOCKS, blocks)?;
        Ok(c)
    }

    fn set(&self, param: raw::TJPARAM, value: i32) -> Result<(), JpegError> {
        // SAFETY: a live handle; TurboJPEG validates the parameter and value.
        if unsafe { raw::tj3Set(self.handle, param as c_int, value) } != 0 {
            return Err(self.error());
        }
        Ok(())
    }

    fn error(&self) -> JpegError {
        // SAFETY: a live handle; the string is owned by TurboJPEG and copied at once.
        let message = unsafe { CStr::from_ptr(raw::tj3GetErrorStr(self.handle)) };
        JpegError::Library(message.to_string_lossy().into_owned())
    }

    /// Compress `height` rows of `width` RGBX pixels, rows `pitch` bytes apart.
    pub fn compress(
        &mut self,
        pixels: &[u8],
        width: u32,
        pitch: usize,
        height: u32,
    ) -> Result<Vec<u8>, JpegError> {
        let rgbx = (raw::TJPF_TJPF_RGBX, 4);
        self.compress_as(pixels, (width, pitch, height), rgbx)
    }

    /// Compress `height` rows of `width` one-byte grey pixels (a compressor
    /// made with `grey`), rows `width` bytes apart: no colour conversion.
    pub fn compress_grey(
        &mut self,
        pixels: &[u8],
        width: u32,
        height: u32,
    ) -> Result<Vec<u8>, JpegError> {
        let grey = (raw::TJPF_TJPF_GRAY, 1);
        self.compress_as(pixels, (width, width as usize, height), grey)
    }

    /// Compress pixels of `format`, `bytes` bytes each.
    fn compress_as(
        &mut self,
        pixels: &[u8],
        (width, pitch, height): (u32, usize, u32),
        (format, bytes): (raw::TJPF, usize),
    ) -> Result<Vec<u8>, JpegError> {
        let needed = (height as usize)
            .checked_sub(1)
            .and_then(|rows| rows.checked_mul(pitch))
            .and_then(|n| n.checked_add(width as usize * bytes));
        if needed.is_none_or(|n| pixels.len() < n) || pitch < width as usize * bytes {
            return Err(JpegError::NotRgbx {
                len: pixels.len(),
                width,
                height,
            });
        }
        let (w, p, h) = (
            c_int::try_from(width)?,
            c_int::try_from(pitch)?,
            c_int::try_from(height)?,
        );
        let mut buf: *mut u8 = std::ptr::null_mut();
        let mut size: raw::size_t = 0;
        // SAFETY: `pixels` holds `height` rows of `pitch` bytes (checked
        // above) and outlives the call; TurboJPEG allocates `buf` itself
        // (NOREALLOC is off by default) and we free it below.
        let res = unsafe {
            raw::tj3Compress8(
                self.handle,
                pixels.as_ptr(),
                w,
                p,
                h,
                format,
                &mut buf,
                &mut size,
            )
        };
        let out = if res == 0 && !buf.is_null() {
            // SAFETY: on success `buf` points to `size` bytes TurboJPEG wrote.
            Ok(unsafe { std::slice::from_raw_parts(buf, size as usize) }.to_vec())
        } else {
            Err(self.error())
        };
        if !buf.is_null() {
            // SAFETY: `buf` was allocated by TurboJPEG and is freed once.
            unsafe { raw::tj3Free(buf.cast()) };
        }
        out
    }
}
