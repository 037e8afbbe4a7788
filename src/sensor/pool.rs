//! Frame-sized byte buffers kept from frame to frame: a picture a stage
//! makes anew each frame (the lens's resample, the rolling shutter's
//! turned background and shuttered frame) takes its buffer from a small
//! pool and gives it back when dropped, so that the next frame writes over
//! pages already in memory rather than a fresh zeroed allocation (its page
//! faults and zeroing cost about as much as a pass over the frame).

use std::sync::Mutex;

/// A picture's bytes (RGBA8 for the stages using it): its buffer returns to
/// a pool of a few when dropped, for the next frame's picture.
#[derive(Debug)]
pub struct Picture(Vec<u8>);

/// The spare pictures' buffers (at most [`SPARE`]).
static POOL: Mutex<Vec<Vec<u8>>> = Mutex::new(Vec::new());
const SPARE: usize = 4;

impl Picture {
    /// A buffer of `n` bytes, from the pool where it has one (its bytes
    /// whatever they were: the taker writes every one).
    pub(crate) fn take(n: usize) -> Self {
        let spare = POOL.lock().ok().and_then(|mut p| p.pop());
        let mut buf = spare.unwrap_or_default();
        buf.resize(n, 0);
        Self(buf)
    }

    /// A buffer holding a copy of `bytes`.
    pub(crate) fn copy_of(bytes: &[u8]) -> Self {
        let mut p = Self::take(bytes.len());
        p.0.copy_from_slice(bytes);
        p
    }

    /// The bytes.
    pub fn as_slice(&self) -> &[u8] {
        &self.0
    }
}

impl std::ops::Deref for Picture {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        &self.0
    }
}

impl std::ops::DerefMut for Picture {
    fn deref_mut(&mut self) -> &mut [u8] {
        &mut self.0
    }
}

impl PartialEq<[u8]> for Picture {
    fn eq(&self, other: &[u8]) -> bool {
        self.0 == other
    }
}

impl PartialEq<Vec<u8>> for Picture {
    fn eq(&self, other: &Vec<u8>) -> bool {
        self.0 == *other
    }
}

impl Drop for Picture {
    fn drop(&mut self) {
        if let Ok(mut pool) = POOL.lock()
            && pool.len() < SPARE
        {
            pool.push(std::mem::take(&mut self.0));
        }
    }
}
