//! The every-Kth trial (`batch --every K`, `BatchOptions::every`): frames
//! 0, K, 2K, … with their own indices and names, each byte-identical to the
//! full run's frame of that index; `--limit` counts those frames; an
//! interrupted trial resumes as the same trial, and another step or limit on
//! its folder is refused with a message naming what differs.

use crate::common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use swarmshot::pipeline::{BatchOptions, BatchReport, FramePipeline, Progress, run_batch};
use swarmshot::preset::Preset;

/// 12 frames: the tiny preset's 2 × 2 sweep, 3 repeats.
fn preset() -> Preset {
    let mut p = common::tiny_preset();
    p.repeats = 3;
    p
}

fn run(
    preset: &Preset,
    options: &BatchOptions,
    progress: impl FnMut(Progress, &AtomicBool) + Send,
) -> anyhow::Result<BatchReport> {
    let ctx = common::gpu();
    let cancel = AtomicBool::new(false);
    let mut progress = progress;
    run_batch(
        &FramePipeline::new(preset.clone()).expect("pipeline"),
        options,
        &ctx,
        &cancel,
        |p| progress(p, &cancel),
    )
}

fn trial(dir: &Path, every: u64, limit: Option<u64>) -> BatchOptions {
    BatchOptions {
        every: Some(every),
        limit,
        ..BatchOptions::new(dir)
    }
}

/// Every file under `dir/sub` by its path relative to `dir/sub`, with its bytes.
fn files(dir: &Path, sub: &str) -> BTreeMap<PathBuf, Vec<u8>> {
    let root = dir.join(sub);
    common::files_under(&root)
        .into_iter()
        .map(|rel| {
            let bytes = std::fs::read(root.join(&rel)).expect("read");
            (rel, bytes)
        })
        .collect()
}

fn indices(dir: &Path) -> Vec<u64> {
    let manifest = std::fs::read_to_string(dir.join("manifest.jsonl")).expect("manifest");
    manifest
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).expect("json line");
            v["index"].as_u64().expect("index")
        })
        .collect()
}

/// The full run's files of the frames `keep` (by the file's stem).
fn only(all: &BTreeMap<PathBuf, Vec<u8>>, keep: &[u64]) -> BTreeMap<PathBuf, Vec<u8>> {
    let names: Vec<String> = keep.iter().map(|i| format!("{i:08}")).collect();
    all.iter()
        .filter(|(p, _)| {
            let stem = p.file_stem().and_then(|s| s.to_str()).unwrap_or("");
            names.iter().any(|n| n == stem)
        })
        .map(|(p, b)| (p.clone(), b.clone()))
        .collect()
}

#[test]
fn every_kth_frame_equals_the_full_runs_frame_of_that_index() {
    let preset = preset();
    assert_eq!(preset.frame_count(), 12);
    let (full, every3, first2) = (
        tempfile::tempdir().expect("tempdir"),
        tempfile::tempdir().expect("tempdir"),
        tempfile::tempdir().expect("tempdir"),
    );
    run(&preset, &BatchOptions::new(full.path()), |_, _| {}).expect("full run");
    let report = run(&preset, &trial(every3.path(), 3, None), |_, _| {}).expect("trial");
    assert_eq!((report.made, report.stats.frames), (4, 4));
    assert_eq!(indices(every3.path()), vec![0, 3, 6, 9]);
    for sub in ["images", "labels"] {
        let all = files(full.path(), sub);
        assert_eq!(all.len(), 12, "{sub}");
        assert_eq!(
            files(every3.path(), sub),
            only(&all, &[0, 3, 6, 9]),
            "{sub}"
        );
    }
    // The trial's manifest lines are the full run's lines of those frames.
    let full_lines: Vec<String> = std::fs::read_to_string(full.path().join("manifest.jsonl"))
        .expect("manifest")
        .lines()
        .map(str::to_owned)
        .collect();
    let trial_lines = std::fs::read_to_string(every3.path().join("manifest.jsonl")).expect("m");
    let expected: Vec<&str> = [0, 3, 6, 9]
        .iter()
        .map(|&i| full_lines[i].as_str())
        .collect();
    assert_eq!(trial_lines.lines().collect::<Vec<_>>(), expected);

    // --limit counts the trial's frames: the first 2 of every 5th.
    let report = run(&preset, &trial(first2.path(), 5, Some(2)), |_, _| {}).expect("limited");
    assert_eq!(report.made, 2);
    assert_eq!(indices(first2.path()), vec![0, 5]);
    assert_eq!(
        files(first2.path(), "images"),
        only(&files(full.path(), "images"), &[0, 5])
    );
}

#[test]
fn an_interrupted_trial_resumes_as_the_same_trial() {
    let preset = preset();
    let (whole, cut) = (
        tempfile::tempdir().expect("tempdir"),
        tempfile::tempdir().expect("tempdir"),
    );
    run(&preset, &trial(whole.path(), 2, None), |_, _| {}).expect("whole trial");
    let report = run(&preset, &trial(cut.path(), 2, None), |p, cancel| {
        if p.done >= 2 {
            cancel.store(true, Ordering::Relaxed);
        }
    })
    .expect("cut trial");
    assert!(report.cancelled);
    assert_eq!(indices(cut.path()), vec![0, 2]);

    // Another step or limit on that folder is refused, naming what differs.
    let e = run(&preset, &trial(cut.path(), 3, None), |_, _| {}).expect_err("other step");
    let e = format!("{e:#}");
    assert!(e.contains("--every differs"), "{e}");
    assert!(
        e.contains("--every 2 over the first 12 frames (6 frames)"),
        "{e}"
    );
    let e = run(&preset, &trial(cut.path(), 2, Some(3)), |_, _| {}).expect_err("other limit");
    assert!(format!("{e:#}").contains("--limit differs"), "{e:#}");
    // A full run is another run too.
    let e = run(&preset, &BatchOptions::new(cut.path()), |_, _| {}).expect_err("full run");
    assert!(format!("{e:#}").contains("--every differs"), "{e:#}");

    // --resume without --every continues the trial from its first missing frame.
    let resume = BatchOptions {
        resume: true,
        ..BatchOptions::new(cut.path())
    };
    let report = run(&preset, &resume, |_, _| {}).expect("resumed");
    assert_eq!((report.resumed_at(), report.made), (Some(4), 4));
    assert_eq!(indices(cut.path()), vec![0, 2, 4, 6, 8, 10]);
    for sub in ["images", "labels", "annotations"] {
        assert_eq!(files(cut.path(), sub), files(whole.path(), sub), "{sub}");
    }
    let m = |d: &Path| std::fs::read(d.join("manifest.jsonl")).expect("manifest");
    assert_eq!(m(cut.path()), m(whole.path()));
    // Done: the same command again has nothing to do.
    let again = run(&preset, &trial(cut.path(), 2, None), |_, _| {}).expect("again");
    assert!(again.already_complete());
}

#[test]
fn every_refuses_what_it_cannot_hold() {
    let dir = tempfile::tempdir().expect("tempdir");
    let e = run(&preset(), &trial(dir.path(), 0, None), |_, _| {}).expect_err("every 0");
    assert!(format!("{e}").contains("--every 0"), "{e}");
    let e = run(
        &common::sequence_preset(),
        &trial(dir.path(), 2, None),
        |_, _| {},
    )
    .expect_err("sequences");
    assert!(format!("{e}").contains("sequence"), "{e}");
    // Nothing was written.
    assert_eq!(std::fs::read_dir(dir.path()).expect("dir").count(), 0);
}
