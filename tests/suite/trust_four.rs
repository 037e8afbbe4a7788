//! Output-folder trust, round four (issue 35; docs/reliability.md): a folder
//! swapped for a symbolic link while a batch or a merge runs redirects no
//! write, and the run stops naming it; report folders (`stats`, `gap`) never write
//! through a link; a run killed before its first ledger existed continues; a
//! finished `--every K` trial run again is already complete. Every command
//! runs as a child process, as a user runs it (renders on lavapipe).

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use std::time::{Duration, Instant};

use swarmshot::preset::LabelFormat;

use common::cli::{command, err, jpeg_preset as preset, ok};

fn args(words: &[&dyn AsRef<std::ffi::OsStr>]) -> Vec<std::ffi::OsString> {
    words.iter().map(|w| w.as_ref().to_owned()).collect()
}

/// Every file under `dir` with its bytes and modification time (the lock aside).
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>, std::time::SystemTime)> {
    common::files_under(dir)
        .into_iter()
        .filter(|rel| rel != Path::new(".swarmshot-lock"))
        .map(|rel| {
            let p = dir.join(&rel);
            let m = std::fs::symlink_metadata(&p).expect("stat");
            let bytes = std::fs::read(&p).unwrap_or_default();
            (rel, bytes, m.modified().expect("mtime"))
        })
        .collect()
}

/// A folder outside the dataset holding one file; returns it and the file's bytes.
fn decoy(tmp: &Path) -> (PathBuf, Vec<u8>) {
    let other = tmp.join("other");
    std::fs::create_dir(&other).expect("mkdir");
    let bytes = b"not swarmshot's".to_vec();
    std::fs::write(other.join("00000002.jpg"), &bytes).expect("write");
    (other, bytes)
}

fn assert_untouched(other: &Path, bytes: &[u8]) {
    let names: Vec<_> = std::fs::read_dir(other)
        .expect("read_dir")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(
        names,
        vec!["00000002.jpg"],
        "files were written into the other folder"
    );
    assert_eq!(
        std::fs::read(other.join("00000002.jpg")).expect("read"),
        bytes
    );
}

/// Run `cmd` stalled at `at` (tests hook), then, while it waits, swap
/// `dir` for a link to `other`; let it go on and return its output.
fn swap_while_stalled(mut cmd: Command, at: &str, dir: &Path, other: &Path, tmp: &Path) -> Output {
    let go = tmp.join("go");
    let stalled = tmp.join("go.stalled");
    let mut child: Child = cmd
        .env("SWARMSHOT_STALL_AT", at)
        .env("SWARMSHOT_STALL_UNTIL", &go)
        .spawn()
        .expect("spawn");
    let t = Instant::now();
    while !stalled.exists() {
        if let Some(status) = child.try_wait().expect("try_wait") {
            panic!("the command ended ({status}) before it stalled at {at}");
        }
        assert!(
            t.elapsed() < Duration::from_secs(240),
            "never stalled at {at}"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let held = dir.with_extension("held");
    std::fs::rename(dir, &held).expect("move the folder away");
    std::os::unix::fs::symlink(other, dir).expect("symlink");
    std::fs::write(&go, "").expect("go");
    let out = child.wait_with_output().expect("wait");
    // Put the folder back, as the user would after the error.
    std::fs::remove_file(dir).expect("rm link");
    std::fs::rename(&held, dir).expect("move back");
    let _ = std::fs::remove_file(&go);
    let _ = std::fs::remove_file(&stalled);
    out
}

#[test]
fn a_folder_swapped_for_a_link_during_a_batch_redirects_no_write() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = common::preset_file(tmp.path(), &preset(3), "p.ron");
    let reference = tmp.path().join("ref");
    ok(&args(&[&"batch", &p, &"--out", &reference]));
    let (other, bytes) = decoy(tmp.path());
    let out = tmp.path().join("ds");
    let o = swap_while_stalled(
        command(&args(&[&"batch", &p, &"--out", &out])),
        "checkpoint:1",
        &out.join("images/train"),
        &other,
        tmp.path(),
    );
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success(),
        "the batch went on through a swapped folder"
    );
    assert!(e.contains("images/train") && e.contains("replaced"), "{e}");
    assert_untouched(&other, &bytes);
    // Nothing lost: the run continues where it stopped, byte for byte.
    ok(&args(&[&"batch", &p, &"--out", &out, &"--resume"]));
    common::assert_same_dataset(&reference, &out, "resumed after the swap");
}

#[test]
fn a_folder_swapped_for_a_link_during_a_merge_redirects_no_write() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = common::preset_file(tmp.path(), &preset(2), "p.ron");
    let single = tmp.path().join("single");
    ok(&args(&[&"batch", &p, &"--out", &single]));
    let shards: Vec<PathBuf> = (0..2)
        .map(|k| {
            let out = tmp.path().join(format!("shard-{k}"));
            ok(&args(&[
                &"batch",
                &p,
                &"--out",
                &out,
                &"--shard",
                &format!("{k}/2"),
            ]));
            out
        })
        .collect();
    let first = common::files_under(&shards[0])
        .into_iter()
        .filter(|r| r.starts_with("images/train"))
        .min()
        .expect("a training image in shard 0");
    let (other, bytes) = decoy(tmp.path());
    let merged = tmp.path().join("merged");
    let o = swap_while_stalled(
        command(&args(&[&"merge", &merged, &shards[0], &shards[1]])),
        &first.to_string_lossy(),
        &merged.join("images/train"),
        &other,
        tmp.path(),
    );
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success(),
        "the merge went on through a swapped folder"
    );
    assert!(e.contains("images/train") && e.contains("replaced"), "{e}");
    assert_untouched(&other, &bytes);
    ok(&args(&[&"merge", &merged, &shards[0], &shards[1]]));
    common::assert_same_dataset(&single, &merged, "merged after the swap");
}

#[test]
fn stats_plots_never_write_through_a_link() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let mut pr = preset(1);
    pr.output.label_formats = vec![LabelFormat::Yolo];
    let p = common::preset_file(tmp.path(), &pr, "p.ron");
    let ds = tmp.path().join("ds");
    ok(&args(&[&"batch", &p, &"--out", &ds, &"--labels-only"]));
    let outside = tmp.path().join("precious.png");
    std::fs::write(&outside, b"precious").expect("write");
    std::fs::create_dir(ds.join("stats-plots")).expect("mkdir");
    std::os::unix::fs::symlink(&outside, ds.join("stats-plots/box_size.png")).expect("symlink");
    let e = err(&args(&[&"stats", &ds]));
    assert!(
        e.contains("box_size.png") && e.contains("symbolic link"),
        "{e}"
    );
    assert_eq!(std::fs::read(&outside).expect("read"), b"precious");
    // Without the link the plots are written.
    std::fs::remove_file(ds.join("stats-plots/box_size.png")).expect("rm");
    ok(&args(&[&"stats", &ds]));
    assert!(
        std::fs::read(ds.join("stats-plots/box_size.png"))
            .expect("png")
            .starts_with(b"\x89PNG")
    );
}

#[test]
fn the_gap_report_never_writes_through_a_link() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = common::preset_file(tmp.path(), &preset(1), "p.ron");
    let synthetic = tmp.path().join("ds");
    ok(&args(&[&"batch", &p, &"--out", &synthetic]));
    let real = common::testdata("real");
    let report = tmp.path().join("report");
    std::fs::create_dir(&report).expect("mkdir");
    let outside = tmp.path().join("precious.json");
    std::fs::write(&outside, b"precious").expect("write");
    std::os::unix::fs::symlink(&outside, report.join("report.json")).expect("symlink");
    let gap = args(&[
        &"gap",
        &"--real",
        &real,
        &"--synthetic",
        &synthetic,
        &"--out",
        &report,
    ]);
    let e = err(&gap);
    assert!(
        e.contains("report.json") && e.contains("symbolic link"),
        "{e}"
    );
    assert_eq!(std::fs::read(&outside).expect("read"), b"precious");
    std::fs::remove_file(report.join("report.json")).expect("rm");
    ok(&gap);
    assert!(
        std::fs::read_to_string(report.join("report.json"))
            .expect("report")
            .starts_with('{')
    );
}

#[test]
fn a_run_killed_before_its_first_ledger_continues() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = common::preset_file(tmp.path(), &preset(1), "p.ron");
    let reference = tmp.path().join("ref");
    ok(&args(&[&"batch", &p, &"--out", &reference]));
    // What a kill leaves while only the first ledger's temporary file exists.
    let killed = |name: &str| {
        let out = tmp.path().join(name);
        std::fs::create_dir(&out).expect("mkdir");
        std::fs::write(out.join("..swarmshot-ledger.tmp"), "swarmshot-led").expect("tmp");
        std::fs::write(out.join(".swarmshot-lock"), "4242\n").expect("lock");
        out
    };
    let resumed = killed("resumed");
    ok(&args(&[&"batch", &p, &"--out", &resumed, &"--resume"]));
    common::assert_same_dataset(&reference, &resumed, "--resume after the kill");
    let rerun = killed("rerun");
    ok(&args(&[&"batch", &p, &"--out", &rerun]));
    common::assert_same_dataset(&reference, &rerun, "a plain rerun after the kill");
    // A folder holding a file of the user's still is not taken.
    let foreign = killed("foreign");
    std::fs::write(foreign.join("notes.txt"), "mine").expect("write");
    let e = err(&args(&[&"batch", &p, &"--out", &foreign, &"--resume"]));
    assert!(e.contains("nothing to resume"), "{e}");
    assert_eq!(
        std::fs::read(foreign.join("notes.txt")).expect("read"),
        b"mine"
    );
}

#[test]
fn a_finished_trial_run_again_is_already_complete() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = common::preset_file(tmp.path(), &preset(3), "p.ron");
    let out = tmp.path().join("trial");
    let trial = args(&[&"batch", &p, &"--out", &out, &"--every", &"7"]);
    ok(&trial);
    let before = snapshot(&out);
    assert!(
        before.iter().any(|(r, ..)| r.starts_with("images")),
        "no image written"
    );
    std::thread::sleep(Duration::from_millis(20));
    ok(&trial);
    assert!(
        snapshot(&out) == before,
        "the same command again changed the finished trial"
    );
    let mut resume = trial.clone();
    resume.push("--resume".into());
    ok(&resume);
    assert!(
        snapshot(&out) == before,
        "--resume re-rendered the finished trial"
    );
}

#[test]
fn an_unknown_built_in_model_is_named_with_its_preset_file() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = tmp.path().join("my-swarm.ron");
    std::fs::write(
        &p,
        r#"(models: [(source: Builtin("quad_zz"), size_m: 0.3, class: "uav")])"#,
    )
    .expect("write");
    for cmd in ["check", "batch"] {
        let mut words = args(&[&cmd, &p]);
        if cmd == "batch" {
            words.extend(args(&[&"--out", &tmp.path().join("ds")]));
        }
        let e = err(&words);
        assert!(
            e.contains("my-swarm.ron") && e.contains("quad_zz"),
            "{cmd}: {e}"
        );
    }
    assert!(
        !tmp.path().join("ds").exists(),
        "the refused batch made its folder"
    );
}
