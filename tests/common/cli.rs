//! The command line run as a user runs it: the test build's `swarmshot` as a child
//! process, its output captured, success or a named error asserted.

use std::process::{Command, Output, Stdio};

use swarmshot::preset::{ImageFormat, LabelFormat, Preset};

/// The test build's binary (with the `test-hooks` fault injection).
pub const BIN: &str = env!("CARGO_BIN_EXE_swarmshot");

/// 320×180 JPEG frames, YOLO and COCO, `repeats` × 4 frames.
pub fn jpeg_preset(repeats: u32) -> Preset {
    let mut p = super::tiny_preset();
    p.repeats = repeats;
    p.output.image_format = ImageFormat::Jpeg { quality: 85 };
    p.output.label_formats = vec![LabelFormat::Yolo, LabelFormat::Coco];
    p
}

/// `swarmshot ARGS` with no backtrace and no scheduler variables, output piped.
pub fn command<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Command {
    let mut cmd = Command::new(BIN);
    cmd.args(args)
        .env("RUST_BACKTRACE", "0")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    cmd
}

pub fn run<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    command(args).output().expect("run swarmshot")
}

/// Runs and asserts success; returns what it printed (stderr, then stdout).
pub fn ok<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> String {
    let o = run(args);
    let text =
        String::from_utf8_lossy(&o.stderr).into_owned() + &String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "swarmshot failed:\n{text}");
    text
}

/// Runs and asserts a named error (`error: …` on stderr); returns stderr.
pub fn err<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> String {
    let o = run(args);
    assert!(!o.status.success(), "swarmshot should have failed");
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(e.contains("error: "), "not a named error: {e}");
    e
}

/// An argument as the command line takes it (a `&str`, a `Path`, an `OsStr`).
pub fn os<S: AsRef<std::ffi::OsStr> + ?Sized>(s: &S) -> &std::ffi::OsStr {
    s.as_ref()
}

/// `swarmshot batch PRESET --out OUT EXTRA…`, which must succeed; what it printed.
pub fn batch(preset: &std::path::Path, out: &std::path::Path, extra: &[&str]) -> String {
    ok(&batch_args(preset, out, extra))
}

/// The arguments `batch PRESET --out OUT EXTRA…`.
pub fn batch_args<'a>(
    preset: &'a std::path::Path,
    out: &'a std::path::Path,
    extra: &[&'a str],
) -> Vec<&'a std::ffi::OsStr> {
    let mut args = vec![
        os("batch"),
        preset.as_os_str(),
        os("--out"),
        out.as_os_str(),
    ];
    args.extend(extra.iter().map(|s| os(*s)));
    args
}
