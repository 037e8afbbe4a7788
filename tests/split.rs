//! Splits without leakage (docs/conventions.md, "Splits"): split by camera
//! pose, sweep point or environment, no group has frames in two splits, the
//! groups per split are the documented round(G·train) / round(G·(train +
//! val)) − round(G·train) / the rest, and the per-frame default is the split
//! it always was. Geometry only (no GPU).

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{Preset, SplitBy};
use swarmshot::scene::split::{group_counts, group_of, groups};
use swarmshot::scene::{SplitName, build_frame};

fn repo_preset(rel: &str) -> Preset {
    Preset::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)).expect("repo preset loads")
}

/// 3 × 2 × 2 camera poses, 2 plane turns, 3 repeats: 72 frames.
fn swept() -> Preset {
    let mut p = common::tiny_preset();
    p.camera.x = SweepRange::new(-0.2, 0.2, 0.2);
    p.camera.y = SweepRange::new(-0.2, 0.2, 0.4);
    p.camera.z = SweepRange::new(0.8, 1.2, 0.4);
    p.plane.ry = SweepRange::new(0.0, 90.0, 90.0);
    p.repeats = 3;
    p
}

/// Every frame's (group, split); asserts each group sits in one split and
/// returns frames and groups per split.
fn check_groups(p: &Preset, what: &str) -> ([u64; 3], [u64; 3]) {
    let g = groups(p).expect("a grouped split");
    let mut split_of_group: BTreeMap<u64, SplitName> = BTreeMap::new();
    let mut frames = [0u64; 3];
    for i in 0..p.frame_count() {
        let scene = build_frame(p, i).expect("frame");
        let (group, n) = group_of(p, i, &scene.environment).expect("grouped");
        assert_eq!(n, g);
        assert!(group < g);
        let first = *split_of_group.entry(group).or_insert(scene.split);
        assert_eq!(
            first, scene.split,
            "{what}: group {group} has frames in {first:?} and {:?}",
            scene.split
        );
        frames[scene.split as usize] += 1;
    }
    let mut per_split = [0u64; 3];
    for s in split_of_group.values() {
        per_split[*s as usize] += 1;
    }
    (frames, per_split)
}

#[test]
fn grouped_splits_keep_groups_whole_at_the_documented_shares() {
    let mut p = swept();
    assert_eq!(p.frame_count(), 72);
    // 12 camera poses of 6 frames: round(8.4) = 8 train, round(9.6) − 8 = 2 val, 2 test.
    p.output.split.by = SplitBy::CameraPose;
    let (frames, per) = check_groups(&p, "camera pose");
    assert_eq!(per, [8, 2, 2]);
    assert_eq!(group_counts(&p, 12), [8, 2, 2]);
    assert_eq!(frames, [48, 12, 12]);
    // 24 sweep points of 3 frames: round(16.8) = 17, round(19.2) − 17 = 2, 5.
    p.output.split.by = SplitBy::SweepPoint;
    let (frames, per) = check_groups(&p, "sweep point");
    assert_eq!(per, [17, 2, 5]);
    assert_eq!(frames, [51, 6, 15]);
    // Other shares, other seeds: always the rounded counts, always whole groups.
    for (seed, (train, val, test)) in [(1, (0.8, 0.1, 0.1)), (2, (0.5, 0.25, 0.25))] {
        p.seed = seed;
        p.output.split.train = train;
        p.output.split.val = val;
        p.output.split.test = test;
        for by in [SplitBy::CameraPose, SplitBy::SweepPoint] {
            p.output.split.by = by;
            let g = groups(&p).expect("groups");
            let (frames, per) = check_groups(&p, &format!("{by:?} seed {seed}"));
            assert_eq!(per, group_counts(&p, g));
            let size = p.frame_count() / g;
            assert_eq!(frames, per.map(|n| n * size));
            let [a, b, _] = per;
            assert_eq!(a, (g as f64 * train).round() as u64);
            assert_eq!(a + b, (g as f64 * (train + val)).round() as u64);
        }
    }
    // The ranking depends on the seed.
    let mut a = swept();
    a.output.split.by = SplitBy::SweepPoint;
    let mut b = a.clone();
    b.seed += 1;
    let splits = |p: &Preset| -> Vec<SplitName> {
        (0..p.frame_count())
            .map(|i| build_frame(p, i).expect("frame").split)
            .collect()
    };
    assert_ne!(splits(&a), splits(&b));
}

#[test]
fn environments_and_sequences_stay_whole() {
    // Seven environments: 5 train, 1 val, 1 test.
    let mut p = repo_preset("presets/environments.ron");
    p.output.split.by = SplitBy::Environment;
    let (frames, per) = check_groups(&p, "environment");
    assert_eq!(per.iter().sum::<u64>(), 7 - per_missing(&p));
    assert!(per[0] <= 5 && per[1] <= 1 && per[2] <= 1, "{per:?}");
    assert_eq!(group_counts(&p, 7), [5, 1, 1]);
    assert_eq!(frames.iter().sum::<u64>(), p.frame_count());

    // Sequence mode: a sequence keeps its sweep values and environment, so
    // every mode keeps it in one split.
    let mut p = repo_preset("presets/formation_sequence.ron");
    let len = p.sequence_len();
    assert!(len > 1);
    for by in [SplitBy::Frame, SplitBy::CameraPose, SplitBy::SweepPoint] {
        p.output.split.by = by;
        for first in (0..p.frame_count()).step_by(len as usize) {
            let split = build_frame(&p, first).expect("frame").split;
            for i in first..first + len {
                assert_eq!(build_frame(&p, i).expect("frame").split, split, "{by:?}");
            }
        }
    }
}

/// Environments no frame of `p` drew (their groups hold no frame).
fn per_missing(p: &Preset) -> u64 {
    let drawn: std::collections::BTreeSet<usize> = (0..p.frame_count())
        .map(|i| build_frame(p, i).expect("frame").environment.choice)
        .collect();
    7 - drawn.len() as u64
}

#[test]
fn the_per_frame_default_is_unchanged_and_left_out_of_the_lock() {
    let p = swept();
    assert_eq!(p.output.split.by, SplitBy::Frame);
    // The split draw of each frame against the cumulative shares, as always.
    for i in 0..p.frame_count() {
        let u = swarmshot::seed::split_uniform(p.seed, i);
        let want = if u < 0.7 {
            SplitName::Train
        } else if u < 0.8 {
            SplitName::Val
        } else {
            SplitName::Test
        };
        assert_eq!(build_frame(&p, i).expect("frame").split, want);
    }
    assert!(groups(&p).is_none());
    // The locked preset keeps its bytes: `by` is written only when not Frame.
    assert!(!p.to_ron().contains("by:"));
    let mut q = p.clone();
    q.output.split.by = SplitBy::CameraPose;
    let text = q.to_ron();
    assert!(text.contains("by: CameraPose"), "{text}");
    assert_eq!(Preset::from_ron(&text).expect("round trip"), q);
}

#[test]
fn a_split_left_without_a_group_is_warned_about() {
    let mut p = common::tiny_preset(); // 2 camera poses
    p.output.split.by = SplitBy::CameraPose;
    let warnings: Vec<String> = swarmshot::pipeline::check::warnings(&p)
        .iter()
        .map(|w| w.to_string())
        .collect();
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("output.split.by") && w.contains("test gets no frame")),
        "{warnings:?}"
    );
    p.output.split.by = SplitBy::Environment; // one sky: one group
    let warnings: Vec<String> = swarmshot::pipeline::check::warnings(&p)
        .iter()
        .map(|w| w.to_string())
        .collect();
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("1 group (1 train / 0 val / 0 test)")),
        "{warnings:?}"
    );
    assert!(
        swarmshot::pipeline::check::warnings(&swept())
            .iter()
            .all(|w| !w.to_string().contains("split"))
    );
}

#[test]
fn check_prints_the_groups_per_split() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let mut p = swept();
    p.output.split.by = SplitBy::CameraPose;
    let file = tmp.path().join("p.ron");
    std::fs::write(&file, p.to_ron()).expect("preset");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_swarmshot"))
        .arg("check")
        .arg(&file)
        .output()
        .expect("run swarmshot check");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        out.contains("split by CameraPose: 12 groups, 8 train / 2 val / 2 test"),
        "{out}"
    );
}
