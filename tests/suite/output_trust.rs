//! Output-folder trust, round three (issue 25; docs/reliability.md): one
//! writer per folder, no link followed under the output folder or a shard,
//! a refused resume that changes nothing, `swarmshot merge` checking every
//! shard file against its ledger record, and a clean stop on SIGINT. Every
//! command runs as a child process, as a user runs it (renders on lavapipe).

use crate::common;

use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

use common::cli::{command, err, jpeg_preset as preset, ok};

fn batch_args(preset: &Path, out: &Path, extra: &[&str]) -> Vec<std::ffi::OsString> {
    let mut args: Vec<std::ffi::OsString> =
        vec!["batch".into(), preset.into(), "--out".into(), out.into()];
    args.extend(extra.iter().map(Into::into));
    args
}

/// Every file under `dir` with its bytes (links as their target text),
/// the lock file aside (a killed run's is taken over and deleted).
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    common::files_under(dir)
        .into_iter()
        .filter(|rel| rel != Path::new(".swarmshot-lock"))
        .map(|rel| {
            let p = dir.join(&rel);
            let bytes = match std::fs::read_link(&p) {
                Ok(target) => target.to_string_lossy().into_owned().into_bytes(),
                Err(_) => std::fs::read(&p).expect("read"),
            };
            (rel, bytes)
        })
        .collect()
}

/// A file's bytes, with the dataset's own absolute path (data.yaml) made neutral.
fn bytes(dir: &Path, rel: &Path) -> Vec<u8> {
    let b = std::fs::read(dir.join(rel)).unwrap_or_else(|e| panic!("{}: {e}", rel.display()));
    if rel == Path::new("data.yaml") {
        let abs = std::fs::canonicalize(dir).expect("canonical");
        return String::from_utf8_lossy(&b)
            .replace(&abs.to_string_lossy().into_owned(), "ROOT")
            .into_bytes();
    }
    b
}

/// `got` holds exactly the files of `want` (the ledger aside), byte for byte.
fn assert_same_dataset(want: &Path, got: &Path, what: &str) {
    let ledger = Path::new(".swarmshot-ledger");
    let list = |d: &Path| -> Vec<PathBuf> {
        common::files_under(d)
            .into_iter()
            .filter(|p| p != ledger)
            .collect()
    };
    let fw = list(want);
    assert_eq!(fw, list(got), "{what}: file lists differ");
    for rel in &fw {
        assert!(
            bytes(want, rel) == bytes(got, rel),
            "{what}: {} differs from the uninterrupted run",
            rel.display()
        );
    }
}

/// Wait until `ready` holds, failing if the child exits first.
fn wait_for(child: &mut Child, what: &str, ready: impl Fn() -> bool) {
    let t = Instant::now();
    while !ready() {
        if let Some(status) = child.try_wait().expect("try_wait") {
            panic!("the batch ended ({status}) before {what}");
        }
        assert!(t.elapsed() < Duration::from_secs(240), "{what} never came");
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn ledger(dir: &Path) -> String {
    std::fs::read_to_string(dir.join(".swarmshot-ledger")).unwrap_or_default()
}

fn checkpoints(dir: &Path) -> usize {
    ledger(dir).lines().filter(|l| l.starts_with('=')).count()
}

/// The dataset in `dir` is whole: one manifest line per image, each COCO file parses.
fn assert_valid(dir: &Path, frames: usize) {
    let manifest = std::fs::read_to_string(dir.join("manifest.jsonl")).expect("manifest");
    assert_eq!(manifest.lines().count(), frames, "manifest lines");
    for line in manifest.lines() {
        serde_json::from_str::<serde_json::Value>(line).expect("manifest line is JSON");
    }
    let images: usize = ["train", "val", "test"]
        .iter()
        .map(|s| std::fs::read_dir(dir.join("images").join(s)).map_or(0, |d| d.count()))
        .sum();
    assert_eq!(images, frames, "images");
    for split in ["train", "val", "test"] {
        let text = std::fs::read_to_string(dir.join(format!("annotations/instances_{split}.json")))
            .expect("COCO file");
        let coco: serde_json::Value = serde_json::from_str(&text).expect("COCO parses");
        assert!(coco["images"].is_array() && coco["annotations"].is_array());
    }
}

#[test]
fn a_second_run_into_a_folder_in_use_is_refused_naming_the_process() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = common::preset_file(tmp.path(), &preset(3), "p.ron");
    let out = tmp.path().join("ds");
    let go = tmp.path().join("go");
    // The first run holds the folder at its third checkpoint until `go` exists.
    let mut first = command(&batch_args(&p, &out, &[]))
        .env("SWARMSHOT_STALL_AT", "checkpoint:2")
        .env("SWARMSHOT_STALL_UNTIL", &go)
        .spawn()
        .expect("spawn");
    let stalled = tmp.path().join("go.stalled");
    wait_for(&mut first, "the first run's stall", || stalled.exists());
    let pid = first.id();
    let held = snapshot(&out);
    for extra in [&[][..], &["--resume"], &["--overwrite"], &["--labels-only"]] {
        let e = err(&batch_args(&p, &out, extra));
        assert!(
            e.contains(&format!("in use by process {pid}")) && e.contains(".swarmshot-lock"),
            "{extra:?}: {e}"
        );
    }
    // The refused runs left the folder exactly as the first run had it.
    let now = snapshot(&out);
    let changed: Vec<_> = (now.iter().filter(|f| !held.contains(f)))
        .map(|f| format!("now {} {}", f.0.display(), f.1.len()))
        .chain(
            held.iter()
                .filter(|f| !now.contains(f))
                .map(|f| format!("before {} {}", f.0.display(), f.1.len())),
        )
        .collect();
    assert!(changed.is_empty(), "a refused run changed {changed:?}");
    let lock = std::fs::read_to_string(out.join(".swarmshot-lock")).expect("lock file");
    assert_eq!(lock.trim(), pid.to_string(), "the lock names its holder");
    std::fs::write(&go, "").expect("barrier");
    let o = first.wait_with_output().expect("wait");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_valid(&out, 12);
    // The run that finished leaves no lock file; the folder resumes and overwrites as usual.
    assert!(!out.join(".swarmshot-lock").exists(), "lock file left");
    ok(&batch_args(&p, &out, &["--resume"]));
    ok(&batch_args(&p, &out, &["--overwrite"]));
    assert_valid(&out, 12);
    // A lock file left by a killed run (no process holds it) is taken over.
    std::fs::write(out.join(".swarmshot-lock"), "999999\n").expect("stale lock");
    ok(&batch_args(&p, &out, &["--resume"]));
    ok(&batch_args(&p, &out, &["--overwrite"]));
    assert!(!out.join(".swarmshot-lock").exists());
}

#[test]
fn overwrite_refuses_a_linked_folder_and_deletes_nothing_outside() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = common::preset_file(tmp.path(), &common::sequence_preset(), "p.ron");
    let out = tmp.path().join("ds");
    ok(&batch_args(&p, &out, &[]));
    // The sequence dataset's `gt` folder replaced by a link to a folder outside.
    let gt = out.join("mot/train/seq-00000000/gt");
    assert!(gt.join("gt.txt").is_file(), "the MOT layout changed");
    let outside = tmp.path().join("outside");
    std::fs::create_dir(&outside).expect("mkdir");
    std::fs::write(outside.join("gt.txt"), "keep me").expect("write");
    std::fs::remove_dir_all(&gt).expect("rm gt");
    std::os::unix::fs::symlink(&outside, &gt).expect("symlink");
    let before = snapshot(&out);
    let e = err(&batch_args(&p, &out, &["--overwrite"]));
    assert!(
        e.contains("seq-00000000/gt") && e.contains("symbolic link"),
        "{e}"
    );
    assert_eq!(
        std::fs::read(outside.join("gt.txt")).expect("kept"),
        b"keep me"
    );
    assert!(
        snapshot(&out) == before,
        "the refused --overwrite deleted files"
    );

    // A forged ledger line whose folder is a link: refused the same way.
    std::fs::remove_file(&gt).expect("rm link");
    ok(&batch_args(&p, &out, &["--overwrite"]));
    let evil = out.join("evil");
    std::os::unix::fs::symlink(&outside, &evil).expect("symlink");
    let mut text = ledger(&out);
    text.push_str("*evil/gt.txt\n");
    std::fs::write(out.join(".swarmshot-ledger"), text).expect("forge");
    let before = snapshot(&out);
    let e = err(&batch_args(&p, &out, &["--overwrite"]));
    assert!(e.contains("evil") && e.contains("symbolic link"), "{e}");
    assert_eq!(
        std::fs::read(outside.join("gt.txt")).expect("kept"),
        b"keep me"
    );
    assert!(
        snapshot(&out) == before,
        "the refused --overwrite deleted files"
    );
}

/// Kill a run after its fifth checkpoint (SIGKILL), as a crash would.
fn killed_run(p: &Path, out: &Path) {
    let mut child = command(&batch_args(p, out, &[]))
        .env("SWARMSHOT_STALL_AT", "checkpoint:5")
        .spawn()
        .expect("spawn");
    wait_for(&mut child, "the fifth checkpoint", || checkpoints(out) >= 5);
    // The stall holds it after frame 5's files, before its checkpoint.
    std::thread::sleep(Duration::from_millis(300));
    child.kill().expect("SIGKILL");
    child.wait().expect("wait");
}

#[test]
fn a_refused_resume_writes_nothing_through_links_and_changes_nothing() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = common::preset_file(tmp.path(), &preset(3), "p.ron");
    let reference = tmp.path().join("ref");
    ok(&batch_args(&p, &reference, &[]));

    // manifest.jsonl replaced by a hard link to a file outside.
    let out = tmp.path().join("ds");
    killed_run(&p, &out);
    let outside = tmp.path().join("outside.jsonl");
    std::fs::copy(out.join("manifest.jsonl"), &outside).expect("copy");
    std::fs::remove_file(out.join("manifest.jsonl")).expect("rm");
    std::fs::hard_link(&outside, out.join("manifest.jsonl")).expect("hard link");
    let outside_bytes = std::fs::read(&outside).expect("read");
    let before = snapshot(&out);
    let e = err(&batch_args(&p, &out, &["--resume"]));
    assert!(
        e.contains("manifest.jsonl") && e.contains("hard link"),
        "{e}"
    );
    assert_eq!(std::fs::read(&outside).expect("read"), outside_bytes);
    assert!(
        snapshot(&out) == before,
        "the refused --resume changed the folder"
    );

    // An image replaced by a link: refused by name, the ledger keeps its checkpoints.
    let out2 = tmp.path().join("ds2");
    killed_run(&p, &out2);
    let image = common::files_under(&out2)
        .into_iter()
        .find(|r| r.starts_with("images") && r.extension().is_some_and(|x| x == "jpg"))
        .expect("an image");
    let target = tmp.path().join("target.jpg");
    std::fs::rename(out2.join(&image), &target).expect("move");
    std::os::unix::fs::symlink(&target, out2.join(&image)).expect("symlink");
    let before = snapshot(&out2);
    let e = err(&batch_args(&p, &out2, &["--resume"]));
    assert!(
        e.contains(&image.to_string_lossy().into_owned()) && e.contains("symbolic link"),
        "{e}"
    );
    assert!(
        snapshot(&out2) == before,
        "the refused --resume changed the folder"
    );
    // Put back, the same resume completes the run byte for byte.
    std::fs::remove_file(out2.join(&image)).expect("rm link");
    std::fs::rename(&target, out2.join(&image)).expect("move back");
    ok(&batch_args(&p, &out2, &["--resume"]));
    assert_same_dataset(&reference, &out2, "resumed after the link was removed");
}

fn merge_args(out: &Path, shards: &[PathBuf], extra: &[&str]) -> Vec<std::ffi::OsString> {
    let mut args: Vec<std::ffi::OsString> = vec!["merge".into(), out.into()];
    args.extend(shards.iter().map(Into::into));
    args.extend(extra.iter().map(Into::into));
    args
}

fn copy_dir(from: &Path, to: &Path) {
    for rel in common::files_under(from) {
        let dst = to.join(&rel);
        std::fs::create_dir_all(dst.parent().expect("parent")).expect("mkdir");
        std::fs::copy(from.join(&rel), dst).expect("copy");
    }
}

#[test]
fn merge_checks_every_shard_file_and_never_writes_into_a_shard() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = common::preset_file(tmp.path(), &preset(2), "p.ron");
    let single = tmp.path().join("single");
    ok(&batch_args(&p, &single, &[]));
    let shards: Vec<PathBuf> = (0..2)
        .map(|k| {
            let out = tmp.path().join(format!("shard-{k}"));
            ok(&batch_args(&p, &out, &["--shard", &format!("{k}/2")]));
            out
        })
        .collect();
    let pristine = tmp.path().join("pristine");
    for s in &shards {
        copy_dir(s, &pristine.join(s.file_name().expect("name")));
    }
    let restore = |s: &Path| {
        std::fs::remove_dir_all(s).expect("rm");
        copy_dir(&pristine.join(s.file_name().expect("name")), s);
    };
    let label = |s: &Path| {
        common::files_under(s)
            .into_iter()
            .find(|r| r.starts_with("labels") && r.extension().is_some_and(|x| x == "txt"))
            .expect("a label file")
    };

    // An output folder inside a shard: refused, and the shard gets nothing.
    let before = snapshot(&shards[0]);
    let e = err(&merge_args(&shards[0].join("merged"), &shards, &[]));
    assert!(e.contains("inside shard"), "{e}");
    assert!(snapshot(&shards[0]) == before, "merge wrote into a shard");

    // A shard entry linked to a folder outside, listed in its ledger.
    let outside = tmp.path().join("outside");
    std::fs::create_dir(&outside).expect("mkdir");
    std::fs::write(outside.join("passwd"), "secret").expect("write");
    std::os::unix::fs::symlink(&outside, shards[0].join("extra")).expect("symlink");
    let mut text = ledger(&shards[0]);
    text = text.replacen('\n', "\n*extra/passwd\n", 1);
    std::fs::write(shards[0].join(".swarmshot-ledger"), text).expect("forge");
    let out = tmp.path().join("m1");
    let e = err(&merge_args(&out, &shards, &[]));
    assert!(e.contains("extra") && e.contains("symbolic link"), "{e}");
    assert!(!out.join("extra").exists(), "the linked entry was merged");
    std::fs::remove_file(shards[0].join("extra")).expect("rm link");
    restore(&shards[0]);

    // A label edited after the shard finished.
    let rel = label(&shards[1]);
    let mut edited = std::fs::read(shards[1].join(&rel)).expect("read");
    edited.extend_from_slice(b"0 0.5 0.5 0.1 0.1\n");
    std::fs::write(shards[1].join(&rel), edited).expect("edit");
    let out = tmp.path().join("m2");
    let e = err(&merge_args(&out, &shards, &[]));
    let name = rel.to_string_lossy().into_owned();
    assert!(
        e.contains(&name) && e.contains("changed since the shard finished"),
        "{e}"
    );
    assert!(
        !out.join("manifest.jsonl").exists(),
        "a refused merge wrote files"
    );
    // Same length, other bytes: caught by the hash.
    restore(&shards[1]);
    let mut same_len = std::fs::read(shards[1].join(&rel)).expect("read");
    let last = same_len.len() - 2;
    same_len[last] = if same_len[last] == b'1' { b'2' } else { b'1' };
    std::fs::write(shards[1].join(&rel), same_len).expect("edit");
    let e = err(&merge_args(&tmp.path().join("m3"), &shards, &[]));
    assert!(e.contains(&name) && e.contains("content hash"), "{e}");
    restore(&shards[1]);

    // A deleted image is named as missing.
    let image = common::files_under(&shards[0])
        .into_iter()
        .find(|r| r.starts_with("images"))
        .expect("an image");
    std::fs::remove_file(shards[0].join(&image)).expect("rm");
    let e = err(&merge_args(&tmp.path().join("m4"), &shards, &[]));
    assert!(
        e.contains(&image.to_string_lossy().into_owned()) && e.contains("is missing"),
        "{e}"
    );
    restore(&shards[0]);

    // Whole shards merge into the single run's bytes; --copy leaves no shared file.
    let linked = tmp.path().join("linked");
    ok(&merge_args(&linked, &shards, &[]));
    assert_same_dataset(&single, &linked, "merged");
    let copied = tmp.path().join("copied");
    ok(&merge_args(&copied, &shards, &["--copy"]));
    assert_same_dataset(&single, &copied, "merged with --copy");
    let rel = label(&copied);
    assert_eq!(
        std::fs::metadata(copied.join(&rel)).expect("stat").nlink(),
        1
    );
    assert!(
        std::fs::metadata(linked.join(&rel)).expect("stat").nlink() > 1,
        "without --copy the files are hard-linked"
    );
}

#[test]
fn sigint_stops_cleanly_and_resume_is_byte_identical() {
    stops_cleanly_and_resumes("INT", "stopped by SIGINT/SIGTERM");
}

/// `kill -SIGNAL` after the first checkpoint of a 240-frame batch: a
/// non-zero exit whose message says `says` and names `--resume`, no
/// temporary or lock file left, and `--resume` ends byte-identical to an
/// uninterrupted run.
pub(crate) fn stops_cleanly_and_resumes(signal: &str, says: &str) {
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = common::preset_file(tmp.path(), &preset(60), "p.ron");
    let reference = tmp.path().join("ref");
    ok(&batch_args(&p, &reference, &[]));
    let out = tmp.path().join("ds");
    let mut child = command(&batch_args(&p, &out, &[])).spawn().expect("spawn");
    wait_for(&mut child, "the first checkpoint", || {
        checkpoints(&out) >= 1
    });
    let pid = child.id().to_string();
    let sent = Command::new("kill")
        .args([&format!("-{signal}"), &pid])
        .status()
        .expect("kill");
    assert!(sent.success());
    let o = child.wait_with_output().expect("wait");
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "a stopped batch exits 1: {e}");
    assert!(e.contains(says) && e.contains("--resume"), "{e}");
    let frames = checkpoints(&out);
    assert!(frames < 240, "the batch finished before the signal");
    for rel in common::files_under(&out) {
        assert!(
            !rel.to_string_lossy().ends_with(".tmp"),
            "temporary file left: {}",
            rel.display()
        );
    }
    assert!(!out.join(".swarmshot-lock").exists(), "lock file left");
    ok(&batch_args(&p, &out, &["--resume"]));
    assert_same_dataset(&reference, &out, &format!("resumed after SIG{signal}"));
}
