//! A labels-only plan (`batch --labels-only`) killed with SIGKILL and
//! continued (docs/reliability.md): the plan keeps a chunk's label files
//! until its checkpoint and creates them together on several threads, so a
//! kill may find any part of a chunk's files made. Every file made is
//! claimed in the ledger first, and the continued plan ends byte-identical
//! to an uninterrupted one.

use crate::common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_swarmshot");

/// 2 000 frames (3–6 drones each): seven full chunks of 256 frames and a part.
fn preset_file(dir: &Path) -> PathBuf {
    let mut p = common::tiny_preset();
    p.repeats = 500;
    assert_eq!(p.frame_count(), 2000);
    common::preset_file(dir, &p, "p.ron")
}

fn plan_cmd(preset: &Path, out: &Path, extra: &[&str]) -> Command {
    let mut cmd = Command::new(BIN);
    cmd.args(["batch", "--labels-only", "--threads", "2"])
        .arg(preset)
        .arg("--out")
        .arg(out)
        .args(extra)
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    cmd
}

fn plan_ok(preset: &Path, out: &Path, extra: &[&str]) {
    let o = plan_cmd(preset, out, extra)
        .output()
        .expect("run swarmshot");
    assert!(
        o.status.success(),
        "swarmshot batch --labels-only {extra:?} failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The label files under `out`, relative (a plan makes them in place,
/// never under a temporary name, so they can be listed while it runs).
fn labels(out: &Path) -> Vec<PathBuf> {
    let dir = out.join("labels");
    if !dir.is_dir() {
        return Vec::new();
    }
    common::files_under(&dir)
        .into_iter()
        .map(|p| Path::new("labels").join(p))
        .collect()
}

/// Wait until `ready` holds (or the child exits), then SIGKILL the child.
fn kill_when(mut child: Child, what: &str, ready: impl Fn() -> bool) {
    let t = Instant::now();
    while !ready() {
        if let Some(status) = child.try_wait().expect("try_wait") {
            panic!("the plan ended ({status}) before the kill point {what}");
        }
        assert!(
            t.elapsed() < Duration::from_secs(240),
            "kill point {what} never came"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
    child.kill().expect("SIGKILL");
    child.wait().expect("wait");
}

/// Every label file a killed plan left is claimed in its ledger.
fn assert_claimed(out: &Path) {
    let ledger = std::fs::read_to_string(out.join(".swarmshot-ledger")).expect("ledger");
    let claimed: BTreeSet<&str> = ledger
        .lines()
        .filter_map(|l| l.strip_prefix('+').or_else(|| l.strip_prefix('*')))
        .collect();
    for rel in labels(out) {
        let rel = rel.to_string_lossy().into_owned();
        assert!(
            claimed.contains(rel.as_str()),
            "{rel} exists but is not claimed"
        );
    }
}

#[test]
fn a_killed_plan_continues_to_the_same_bytes() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let preset = preset_file(tmp.path());
    let reference = tmp.path().join("reference");
    plan_ok(&preset, &reference, &[]);
    assert_eq!(labels(&reference).len(), 2000);

    // Chunk 256..512 wholly made (its label files, manifest lines and COCO
    // records) but not checkpointed: the continued plan redoes it over the
    // files already there.
    let out = tmp.path().join("killed-before-checkpoint");
    let child = plan_cmd(&preset, &out, &[])
        .env("SWARMSHOT_STALL_AT", "checkpoint:511")
        .spawn()
        .expect("spawn");
    kill_when(child, "before the second checkpoint", || {
        labels(&out).len() == 512
    });
    assert_claimed(&out);
    plan_ok(&preset, &out, &["--resume"]);
    common::assert_same_dataset(&reference, &out, "killed before a checkpoint");

    // Anywhere while the files of a chunk are being made.
    for n in [1usize, 300, 1000] {
        let out = tmp.path().join(format!("killed-after-{n}"));
        let child = plan_cmd(&preset, &out, &[]).spawn().expect("spawn");
        kill_when(child, &format!("{n} label files"), || {
            labels(&out).len() >= n
        });
        assert_claimed(&out);
        // Rerunning the same command (no --resume) continues too.
        plan_ok(&preset, &out, &[]);
        common::assert_same_dataset(&reference, &out, &format!("killed after {n} label files"));
    }
}
