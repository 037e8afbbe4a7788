//! The files a .gltf names by URI (external buffers and images), confined to
//! the model's folder and read with bounds.
//!
//! The glTF reader would open any path a URI names: `../../etc/passwd`,
//! `/dev/zero`, `file:///dev/zero`, and read it to its end. Here every
//! non-`data:` URI is resolved against the model's folder first: an absolute
//! path, a `file:` URI, a `..` that climbs out of the folder, or a link whose
//! target lies outside it is refused unless the preset allows it
//! (`models[i].allow_uris_outside_folder`); whatever is allowed is then
//! opened without blocking, the *opened* file's type is checked (a device,
//! FIFO, socket or folder is refused however it was named), and at most the
//! declared length is read (a buffer's `byteLength`, an image's
//! [`super::MAX_MODEL_FILE_BYTES`]).

use std::io::Read;
use std::path::{Component, Path, PathBuf};

/// Where a glTF's URIs may point.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UriPolicy {
    /// Absolute paths, `file:` URIs, `..` escapes and links out of the
    /// model's folder are read (off by default). Devices and FIFOs stay refused.
    pub allow_outside_folder: bool,
}

/// What a URI names.
#[derive(Debug, PartialEq, Eq)]
pub enum Target {
    /// `data:` (decoded by the glTF reader).
    Data,
    /// A file on disk, resolved.
    File(PathBuf),
}

const HOW_TO_ALLOW: &str = "only files inside the model's folder are read; set `allow_uris_outside_folder: true` on the model in the preset to allow it";

/// Why a URI's file may not be read. The message is the reason alone: the
/// caller names the model, the buffer or image and the URI.
#[derive(Debug, thiserror::Error)]
pub enum UriError {
    #[error("a model read from memory cannot name external files")]
    NoFolder,
    #[error("{0}; {HOW_TO_ALLOW}")]
    Outside(&'static str),
    #[error("unsupported URI scheme (only relative paths and data: URIs are read)")]
    Scheme,
    #[error("a link leads out of the model's folder (to {}); {HOW_TO_ALLOW}", .0.display())]
    LinkOutside(PathBuf),
    #[error("{0}")]
    Io(#[from] std::io::Error),
    #[error("{0}, not a regular file")]
    NotRegular(&'static str),
    #[error("{len} bytes is larger than the {max}-byte limit")]
    TooLarge { len: u64, max: u64 },
}

/// Resolve `uri` against `base_dir` (the folder holding the .gltf), or say
/// why it may not be read.
pub fn resolve(uri: &str, base_dir: Option<&Path>, policy: UriPolicy) -> Result<Target, UriError> {
    if uri.starts_with("data:") {
        return Ok(Target::Data);
    }
    let Some(base) = base_dir else {
        return Err(UriError::NoFolder);
    };
    // `model.gltf` in the working folder has an empty parent.
    let base = if base.as_os_str().is_empty() {
        Path::new(".")
    } else {
        base
    };
    let outside = |what: &'static str| -> Result<Target, UriError> { Err(UriError::Outside(what)) };
    if let Some(rest) = uri
        .strip_prefix("file://")
        .or_else(|| uri.strip_prefix("file:"))
    {
        if !policy.allow_outside_folder {
            return outside("a `file:` URI names a file by absolute path");
        }
        let path = PathBuf::from(super::percent_decode(rest));
        return checked_link(&path, base, policy).map(Target::File);
    }
    if uri.contains(':') {
        return Err(UriError::Scheme);
    }
    let decoded = PathBuf::from(super::percent_decode(uri));
    if decoded.is_absolute() {
        if !policy.allow_outside_folder {
            return outside("an absolute path is outside the model's folder");
        }
        return checked_link(&decoded, base, policy).map(Target::File);
    }
    // Lexically: a `..` may step back only into the folder.
    let mut depth: usize = 0;
    for c in decoded.components() {
        match c {
            Component::Normal(_) => depth += 1,
            Component::ParentDir => match depth.checked_sub(1) {
                Some(d) => depth = d,
                None if policy.allow_outside_folder => {}
                None => return outside("`..` leads out of the model's folder"),
            },
            Component::CurDir => {}
            Component::RootDir | Component::Prefix(_) => {
                if !policy.allow_outside_folder {
                    return outside("an absolute path is outside the model's folder");
                }
            }
        }
    }
    checked_link(&base.join(&decoded), base, policy).map(Target::File)
}

/// `path` itself, unless links lead it out of `base` (and that is not allowed).
fn checked_link(path: &Path, base: &Path, policy: UriPolicy) -> Result<PathBuf, UriError> {
    if policy.allow_outside_folder {
        return Ok(path.to_owned());
    }
    // A missing file is reported when it is opened, naming the file.
    let (Ok(real), Ok(real_base)) = (path.canonicalize(), base.canonicalize()) else {
        return Ok(path.to_owned());
    };
    if real.starts_with(&real_base) {
        Ok(path.to_owned())
    } else {
        Err(UriError::LinkOutside(real))
    }
}

/// Open `path` without blocking (a FIFO would block `open`) and check the
/// opened file is a regular file of at most `max_bytes`.
pub fn open_regular(path: &Path, max_bytes: u64) -> Result<(std::fs::File, u64), UriError> {
    use std::os::unix::fs::OpenOptionsExt;
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(rustix::fs::OFlags::NONBLOCK.bits() as i32)
        .open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(UriError::NotRegular(crate::input::file_kind(&meta)));
    }
    if meta.len() > max_bytes {
        return Err(UriError::TooLarge {
            len: meta.len(),
            max: max_bytes,
        });
    }
    Ok((file, meta.len()))
}

/// Read at most `take_bytes` of the regular file at `path` (itself at
/// most [`super::MAX_MODEL_FILE_BYTES`]).
pub fn read_bounded(path: &Path, take_bytes: u64) -> Result<Vec<u8>, UriError> {
    let (file, len) = open_regular(path, super::MAX_MODEL_FILE_BYTES)?;
    let mut bytes = Vec::with_capacity(usize::try_from(len.min(take_bytes)).unwrap_or(0));
    file.take(take_bytes).read_to_end(&mut bytes)?;
    Ok(bytes)
}
