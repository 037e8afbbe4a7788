//! Reading the files a user names (presets, models, buffers, images): bounded in
//! size and refusing what is not a regular file, so no input can block a read or
//! make it grow without end. Every stage that reads a user's file goes through here;
//! it imports nothing of the project.

/// Read a file the user named (preset, model, buffer, sky image): a regular
/// file (or a link to one) of at most `max_bytes`. FIFOs, devices such as
/// `/dev/zero`, sockets and folders are refused before they are opened, so a
/// read never blocks or grows without end; the cap is enforced while reading
/// too, in case the file grows.
pub fn read_input_file(path: &std::path::Path, max_bytes: u64) -> std::io::Result<Vec<u8>> {
    use std::io::{Error, ErrorKind, Read};
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        let kind = file_kind(&meta);
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!("{kind}, not a regular file"),
        ));
    }
    let too_large = |n: u64| {
        Error::new(
            ErrorKind::InvalidData,
            format!("{n} bytes is larger than the {max_bytes}-byte limit for this kind of file"),
        )
    };
    if meta.len() > max_bytes {
        return Err(too_large(meta.len()));
    }
    let mut bytes = Vec::with_capacity(usize::try_from(meta.len()).unwrap_or(0));
    std::fs::File::open(path)?
        .take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// What a file that is not a regular file is, for messages.
pub fn file_kind(meta: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if meta.is_dir() {
        "a folder"
    } else {
        "a special file"
    }
}
