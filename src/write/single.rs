//! One frame alone (`swarmshot frame`): the per-frame files the batch writes
//! for that frame, with the same bytes, beside the image the user names
//! instead of in a dataset folder: the image, its YOLO labels (`.txt`), its
//! manifest record (`.json`), and what `output.masks` asks for (YOLO
//! segmentation labels `.seg.txt`, instance PNG `.mask.png`, depth PNG
//! `.depth.png`). Every file is written to a temporary name first, then all are
//! renamed into place (a kill while writing leaves the earlier files whole); the COCO RLE lives only
//! in a dataset's COCO files. The folder they go into is opened once, before the frame
//! is made ([`LoneDir`]), and every file is written relative to that handle: a folder
//! moved away or replaced by a link meanwhile cannot redirect a write.

use std::path::{Path, PathBuf};

use super::folder::tree::Tree;
use super::formats::{masks, yolo};
use super::{
    EncodeError, OutputError, encode_grey_image, encode_image, image_rel_path, manifest_line,
};
use crate::annotate::DroneLabel;
use crate::annotate::masks::FrameMasks;
use crate::preset::ImageFormat;
use crate::preset::masks::MaskOutputs;
use crate::scene::FrameScene;

/// One made frame, as the writer needs it.
pub struct LoneFrame<'a> {
    pub scene: &'a FrameScene,
    pub labels: &'a [DroneLabel],
    /// Tightly packed RGBA8, `scene.camera` sized.
    pub rgba: &'a [u8],
    /// 16-bit grey pixels, written instead of `rgba` (a PNG) when present.
    pub grey16: Option<&'a [u16]>,
    /// `rgba` is grey (R = G = B): a JPEG is written with one channel.
    pub grey: bool,
    /// Each drone's visible pixels (present when `output.masks` asks for any).
    pub masks: Option<&'a FrameMasks>,
}

/// What the preset says about a frame's files.
pub struct LoneFormat<'a> {
    /// The frame's image format (the camera model may draw its JPEG quality).
    pub image: ImageFormat,
    pub masks: &'a MaskOutputs,
    pub model_names: &'a [String],
    pub classes: &'a [String],
}

/// An output name whose extension does not match the preset's image format.
#[derive(Debug, thiserror::Error)]
#[error(
    "--out {}: the preset writes {} images (output.image_format); name the file .{}",
    .out.display(),
    .format.extension().to_uppercase(),
    .format.extension()
)]
pub struct ImageNameError {
    pub out: PathBuf,
    pub format: ImageFormat,
}

/// Refuse an output name whose extension does not match `format` (before
/// anything is made or written).
pub fn check_image_name(out: &Path, format: ImageFormat) -> Result<(), ImageNameError> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let accepted: &[&str] = match format {
        ImageFormat::Jpeg { .. } => &["jpg", "jpeg"],
        ImageFormat::Png => &["png"],
    };
    if ext.as_deref().is_some_and(|e| accepted.contains(&e)) {
        return Ok(());
    }
    Err(ImageNameError {
        out: out.to_owned(),
        format,
    })
}

/// The mask files' suffixes ([`beside`] the image), in the order written.
const MASK_SUFFIXES: [&str; 4] = [".seg.txt", ".mask.png", ".depth.png", ".flow.png"];

/// Every file [`write_lone_frame`] may write for `out` under `masks`, the
/// image first.
pub fn lone_frame_files(out: &Path, masks: &MaskOutputs) -> Vec<PathBuf> {
    let asked = [masks.yolo_seg, masks.instance_png, masks.depth, masks.flow];
    let mut files = vec![
        out.to_owned(),
        out.with_extension("txt"),
        out.with_extension("json"),
    ];
    files.extend(
        (MASK_SUFFIXES.iter().zip(asked))
            .filter(|(_, on)| *on)
            .map(|(suffix, _)| beside(out, suffix)),
    );
    files
}

/// A file the lone frame would write over something it must not replace.
#[derive(Debug, thiserror::Error)]
pub enum LoneTargetError {
    #[error("--out {}: the frame would write {} over {what} {}, which the run reads; name another file", .out.display(), .target.display(), .input.display())]
    Input {
        out: PathBuf,
        target: PathBuf,
        what: &'static str,
        input: PathBuf,
    },
    #[error("--out {}: {} exists; pass --overwrite to replace the files the frame writes ({}), or name another file", .out.display(), .target.display(), .files)]
    Exists {
        out: PathBuf,
        target: PathBuf,
        files: String,
    },
    #[error("--out {}: {} is not a regular file; name another file", .out.display(), .target.display())]
    NotFile { out: PathBuf, target: PathBuf },
}

/// Refuse, before anything is made or written, to write `files` (what
/// [`lone_frame_files`] lists for `out`) over what the run reads (`inputs`:
/// the preset file and [`crate::preset::Preset::input_paths`], each with
/// what it is; a target inside an input folder counts) — always — or over
/// anything that exists unless `overwrite` (then only regular files, which
/// are replaced). Paths compared canonical, links resolved.
pub fn check_lone_targets(
    out: &Path,
    files: &[PathBuf],
    inputs: &[(&'static str, &Path)],
    overwrite: bool,
) -> Result<(), LoneTargetError> {
    let inputs: Vec<_> = (inputs.iter())
        .filter_map(|&(what, p)| Some((what, p, p.canonicalize().ok()?)))
        .collect();
    for target in files {
        if let Ok(real) = crate::input::canonical_as_far_as_it_exists(target)
            && let Some(&(what, input, _)) = inputs.iter().find(|(_, _, i)| real.starts_with(i))
        {
            return Err(LoneTargetError::Input {
                out: out.to_owned(),
                target: target.clone(),
                what,
                input: input.to_owned(),
            });
        }
        let Ok(meta) = std::fs::symlink_metadata(target) else {
            continue;
        };
        if !meta.is_file() {
            return Err(LoneTargetError::NotFile {
                out: out.to_owned(),
                target: target.clone(),
            });
        }
        if !overwrite {
            let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
            return Err(LoneTargetError::Exists {
                out: out.to_owned(),
                target: target.clone(),
                files: names.join(", "),
            });
        }
    }
    Ok(())
}

/// The file beside `out` that holds `suffix` (`f.jpg` → `f.seg.txt`).
fn beside(out: &Path, suffix: &str) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or_else(|| "frame".into(), |s| s.to_string_lossy().into_owned());
    out.with_file_name(format!("{stem}{suffix}"))
}

/// The folder holding `--out`, opened once before the frame is made (see the
/// module docs): a missing folder, or a file name that is not UTF-8 text, is
/// refused then, by name.
pub struct LoneDir {
    out: PathBuf,
    tree: Tree,
    /// `--overwrite`: files at the frame's names are replaced; without it a
    /// file that appears there while the frame is made is kept and refused.
    overwrite: bool,
}

impl LoneDir {
    /// Open the folder `out` is in (`.` for a bare name).
    pub fn open(out: &Path, overwrite: bool) -> Result<Self, OutputError> {
        if out.file_name().and_then(|n| n.to_str()).is_none() {
            return Err(OutputError::Refused {
                path: out.to_owned(),
                reason: "its file name is not UTF-8 text".into(),
            });
        }
        let (dir, _) = dir_and_name(out);
        if std::fs::symlink_metadata(dir).is_err() {
            let reason = format!("its folder {} does not exist", dir.display());
            return Err(OutputError::Io {
                path: out.to_owned(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, reason),
            });
        }
        super::dataset::check_outside_other_datasets(dir)?;
        Ok(Self {
            out: out.to_owned(),
            tree: Tree::open(dir)?,
            overwrite,
        })
    }

    /// `path`'s name in the folder (each file is beside `out`).
    fn name(path: &Path) -> String {
        dir_and_name(path).1
    }
}

/// Write `frame`'s files into `dir`: the image at its `out`, the rest beside
/// it. Returns every path written, the image first.
pub fn write_lone_frame(
    dir: &mut LoneDir,
    frame: &LoneFrame<'_>,
    format: &LoneFormat<'_>,
) -> Result<Vec<PathBuf>, OutputError> {
    super::folder::stall_if_asked("frame:writing");
    let out = dir.out.as_path();
    let (w, h) = (frame.scene.camera.width, frame.scene.camera.height);
    let mut files: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    files.push((
        out.to_owned(),
        match frame.grey16 {
            Some(grey) => super::encode_grey16_png(grey, w, h)?,
            None if frame.grey => encode_grey_image(frame.rgba, w, h, format.image)?,
            None => encode_image(frame.rgba, w, h, format.image)?,
        },
    ));
    files.push((
        out.with_extension("txt"),
        yolo::label_text(frame.scene, frame.labels).into_bytes(),
    ));
    let record = manifest_line(
        frame.scene,
        frame.labels,
        &image_rel_path(frame.scene, format.image),
        format.model_names,
        format.classes,
    );
    files.push((
        out.with_extension("json"),
        format!("{record}\n").into_bytes(),
    ));
    if format.masks.any() {
        let m = frame.masks.ok_or_else(|| OutputError::Encode {
            format: "masks",
            source: EncodeError::NoMasks(frame.scene.index),
        })?;
        let encoded = masks::encode(m, frame.labels, format.masks)?;
        let named = MASK_SUFFIXES.into_iter().zip([
            encoded.yolo_seg,
            encoded.instance_png,
            encoded.depth_png,
            encoded.flow_png,
        ]);
        for (suffix, bytes) in named {
            if let Some(bytes) = bytes {
                files.push((beside(out, suffix), bytes));
            }
        }
    }
    remove_stale_temps(&mut dir.tree, &files);
    stage_then_rename(&mut dir.tree, &files, dir.overwrite)?;
    Ok(files.into_iter().map(|(p, _)| p).collect())
}

/// Write every file to a temporary name first, then rename them into place
/// one after another: a kill or an error while the files are written leaves
/// the files at those names as they were (a kill, also temporary files, which
/// the next `frame` there removes), never some of the new frame's files
/// beside some of the old one's, but for the instants between the renames.
fn stage_then_rename(
    dir: &mut Tree,
    files: &[(PathBuf, Vec<u8>)],
    overwrite: bool,
) -> Result<(), OutputError> {
    let mut staged: Vec<String> = Vec::with_capacity(files.len());
    for (path, bytes) in files {
        match stage(dir, path, bytes) {
            Ok(tmp) => staged.push(tmp),
            Err(e) => {
                remove_all(dir, &staged);
                return Err(e);
            }
        }
    }
    super::folder::stall_if_asked("frame:staged");
    // Without --overwrite, a name taken while the frame was made stops it
    // before any file is put in place (and [`place`] refuses one taken later).
    if let Some((path, _)) = (files.iter())
        .find(|(path, _)| !overwrite && dir.lstat(&LoneDir::name(path)).is_ok_and(|e| e.is_some()))
    {
        remove_all(dir, &staged);
        return Err(taken(path));
    }
    for (i, ((path, _), tmp)) in files.iter().zip(&staged).enumerate() {
        if let Err(e) = place(dir, tmp, path, overwrite) {
            remove_all(dir, &staged[i..]);
            return Err(e);
        }
    }
    Ok(())
}

/// Put the staged file `tmp` at `path`'s name: renamed over what is there
/// with `overwrite`; otherwise hard-linked to the name, which fails on a
/// name taken meanwhile (a rename would replace it), then unlinked (renamed
/// on a file system without hard links).
fn place(dir: &mut Tree, tmp: &str, path: &Path, overwrite: bool) -> Result<(), OutputError> {
    let name = LoneDir::name(path);
    if overwrite {
        return dir.rename(tmp, &name);
    }
    match dir.link_within(tmp, &name) {
        Ok(()) => dir.remove_file(tmp).map(|_| ()),
        Err(_) if dir.lstat(&name)?.is_some() => Err(taken(path)),
        Err(_) => dir.rename(tmp, &name),
    }
}

/// The refusal of a frame file's name taken while the frame was made (without `--overwrite`).
fn taken(path: &Path) -> OutputError {
    OutputError::Refused {
        path: path.to_owned(),
        reason: "appeared while the frame was made; pass --overwrite to replace it".into(),
    }
}

/// Only temporary files this process created.
fn remove_all(dir: &mut Tree, temps: &[String]) {
    for tmp in temps {
        let _ = dir.remove_file(tmp);
    }
}

/// The folder `path` is in (`.` for a bare name) and its file name.
fn dir_and_name(path: &Path) -> (&Path, String) {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path
        .file_name()
        .map_or_else(|| "swarmshot".into(), |n| n.to_string_lossy().into_owned());
    (dir, name)
}

/// The temporary name of `name` for this process: `.NAME.PID.tmp`.
fn temp_name(name: &str) -> String {
    format!(".{name}.{}.tmp", std::process::id())
}

/// `bytes` in a new temporary file beside `path` in `dir` (`.NAME.PID.tmp`,
/// created new: a link or file already at its name is not followed or
/// truncated), flushed to disk. Returns its name.
fn stage(dir: &mut Tree, path: &Path, bytes: &[u8]) -> Result<String, OutputError> {
    use std::io::Write;
    let tmp = temp_name(&LoneDir::name(path));
    let mut file = dir.create_new(&tmp, false)?;
    if let Err(e) = file.write_all(bytes).and_then(|()| file.sync_all()) {
        let _ = dir.remove_file(&tmp);
        return Err(super::io(&dir.root().join(&tmp))(e));
    }
    Ok(tmp)
}

/// Remove the temporary files an earlier `frame` killed while writing these
/// files left (`.NAME.PID.tmp` for each of their names, a regular file, of a
/// process no longer running). On systems without `/proc` every process is
/// taken as running, so nothing is removed.
fn remove_stale_temps(dir: &mut Tree, files: &[(PathBuf, Vec<u8>)]) {
    let Ok(entries) = dir.entries("") else {
        return;
    };
    for (path, _) in files {
        let prefix = format!(".{}.", LoneDir::name(path));
        for (name, entry) in &entries {
            let Some(pid) = name
                .strip_prefix(&prefix)
                .and_then(|rest| rest.strip_suffix(".tmp"))
                .and_then(|pid| pid.parse::<u32>().ok())
            else {
                continue;
            };
            if entry.is_file() && !process_running(pid) {
                let _ = dir.remove_file(name);
            }
        }
    }
}

/// Whether process `pid` runs (Linux: `/proc/PID` exists); elsewhere every
/// process is taken as running.
fn process_running(pid: u32) -> bool {
    !cfg!(target_os = "linux") || Path::new("/proc").join(pid.to_string()).exists()
}
