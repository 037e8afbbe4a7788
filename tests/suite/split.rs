//! Splits (docs/conventions.md, "Splits"): split by camera pose, sweep
//! point or environment, no group has frames in two splits, the groups per
//! split are the documented round(G·train) / round(G·(train + val)) −
//! round(G·train) / the rest (at least one per share above 0); the per-frame
//! draw: every run of 3 frames or more has three non-empty splits, a frame's
//! split is the same in every run, the shares converge; a run that keeps too
//! few groups whole is refused with the groups named. Geometry only (but for
//! one small rendered run).

use crate::common;

use std::collections::BTreeMap;
use std::path::Path;

use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{Preset, SplitBy};
use swarmshot::scene::split::{
    draw_slot, first_block, frame_split_counts, group_counts, group_of, group_slot, groups,
    run_splits,
};
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
fn the_per_frame_default_is_the_documented_draw_and_left_out_of_the_lock() {
    let mut p = swept();
    p.repeats = 40; // 960 frames: block 0 and nine more
    assert_eq!(p.output.split.by, SplitBy::Frame);
    let shares = [0.7, 0.1, 0.2];
    let first = first_block(p.seed, shares);
    // Block 0: its seeded ranks against the shares, the first of each split moved to the front.
    let ranked: Vec<u8> = swarmshot::seed::split_block_order(p.seed, 0)
        .iter()
        .map(|&r| slot((r as f64 + 0.5) / 100.0))
        .collect();
    let firsts: Vec<usize> = (0..3u8)
        .map(|s| ranked.iter().position(|&x| x == s).expect("each split"))
        .collect();
    let mut sorted = firsts.clone();
    sorted.sort_unstable();
    let mut want: Vec<u8> = sorted.iter().map(|&i| ranked[i]).collect();
    want.extend((0..100).filter(|i| !firsts.contains(i)).map(|i| ranked[i]));
    assert_eq!(first.to_vec(), want);
    // Later blocks: the split draw of each frame against the cumulative shares, as always.
    for i in 0..p.frame_count() {
        let want = if i < 100 {
            SPLITS[first[i as usize] as usize]
        } else {
            SPLITS[slot(swarmshot::seed::split_uniform(p.seed, i)) as usize]
        };
        let scene = build_frame(&p, i).expect("frame");
        assert_eq!(scene.split, want, "frame {i}");
        assert_eq!(draw_slot(p.seed, shares, i), want as usize);
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

const SPLITS: [SplitName; 3] = [SplitName::Train, SplitName::Val, SplitName::Test];

/// 70/10/20 against a split draw.
fn slot(u: f64) -> u8 {
    if u < 0.7 {
        0
    } else if u < 0.8 {
        1
    } else {
        2
    }
}

/// Share settings the split tests run over: the default, even, lopsided, and
/// shares under ½ % (which no rank of a block of 100 reaches).
const SHARE_SETTINGS: [[f64; 3]; 6] = [
    [0.7, 0.1, 0.2],
    [0.8, 0.1, 0.1],
    [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
    [0.98, 0.01, 0.01],
    [0.995, 0.004, 0.001],
    [0.05, 0.05, 0.9],
];

#[test]
fn every_run_of_three_frames_or_more_fills_every_split() {
    for seed in [0u64, 1, 7, 42, 1234, u64::MAX] {
        for shares in SHARE_SETTINGS {
            let mut counts = [0u64; 3];
            for i in 0..200u64 {
                counts[draw_slot(seed, shares, i)] += 1;
                if i + 1 >= 3 {
                    assert!(
                        counts.iter().all(|&n| n > 0),
                        "seed {seed}, shares {shares:?}: the first {} frames split {counts:?}",
                        i + 1
                    );
                }
            }
        }
        // A share of 0 gets no frame, and two shares fill from 2 frames on.
        for shares in [[0.8, 0.2, 0.0], [0.9, 0.0, 0.1], [0.0, 0.5, 0.5]] {
            let mut counts = [0u64; 3];
            for i in 0..300u64 {
                counts[draw_slot(seed, shares, i)] += 1;
                for s in 0..3 {
                    if shares[s] == 0.0 {
                        assert_eq!(counts[s], 0, "{shares:?}");
                    } else if i >= 1 {
                        assert!(counts[s] > 0, "seed {seed} {shares:?} at {i}: {counts:?}");
                    }
                }
            }
        }
    }
    // Through the frames themselves, the counts the check uses, and the run walk.
    let mut p = swept();
    p.repeats = 9; // 216 frames
    for seed in [3u64, 99] {
        p.seed = seed;
        let mut counts = [0u64; 3];
        for i in 0..p.frame_count() {
            counts[build_frame(&p, i).expect("frame").split as usize] += 1;
            let n = i + 1;
            assert_eq!(
                Some(counts),
                frame_split_counts(&p, n, u64::MAX),
                "{n} frames"
            );
            if n >= 3 {
                assert!(counts.iter().all(|&c| c > 0), "{n} frames: {counts:?}");
            }
        }
        let run = run_splits(&p, 150, 1, u64::MAX).expect("walked");
        assert_eq!(
            Some(run.frame_counts),
            frame_split_counts(&p, 150, u64::MAX)
        );
    }
}

#[test]
fn a_frame_keeps_its_split_in_every_run() {
    // A pure function of (seed, index): the split of frame i is one thing,
    // whatever the run's length, step or shard. Here: a rendered run of 5
    // frames, labels-only plans of 10 and 120, and the walk of a --every 7
    // trial agree frame by frame with build_frame.
    let tmp = tempfile::tempdir().expect("tempdir");
    let mut p = swept();
    p.repeats = 5; // 120 frames
    let file = common::preset_file(tmp.path(), &p, "p.ron");
    let mut seen: BTreeMap<u64, String> = BTreeMap::new();
    for (name, args) in [
        ("five", &["--limit", "5"][..]),
        ("ten", &["--limit", "10", "--labels-only"][..]),
        ("all", &["--labels-only"][..]),
    ] {
        let out = tmp.path().join(name);
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_swarmshot"))
            .args(["batch".as_ref(), file.as_os_str()])
            .arg("--out")
            .arg(&out)
            .args(args)
            .output()
            .expect("run swarmshot batch");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let manifest = std::fs::read_to_string(out.join("manifest.jsonl")).expect("manifest");
        let mut per = [0u64; 3];
        for line in manifest.lines() {
            let v: serde_json::Value = serde_json::from_str(line).expect("json");
            let i = v["index"].as_u64().expect("index");
            let split = v["split"].as_str().expect("split").to_string();
            let want = format!("{:?}", build_frame(&p, i).expect("frame").split).to_lowercase();
            assert_eq!(split, want, "{name}: frame {i}");
            let earlier = seen.entry(i).or_insert_with(|| split.clone());
            assert_eq!(*earlier, split, "{name}: frame {i}");
            per[["train", "val", "test"]
                .iter()
                .position(|s| *s == split)
                .expect("a split")] += 1;
        }
        assert!(per.iter().all(|&n| n > 0), "{name}: {per:?}");
        if name == "five" {
            // Rendered: data.yaml names each split's own images.
            let yaml = std::fs::read_to_string(out.join("data.yaml")).expect("data.yaml");
            assert!(yaml.contains("val: images/val"), "{name}: {yaml}");
            assert!(yaml.contains("test: images/test"), "{name}: {yaml}");
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(!err.contains("output.split"), "{err}");
        }
    }
    // A step or a range is the same function of the index.
    let walked = run_splits(&p, 120, 7, u64::MAX).expect("walked");
    let mut by_hand = [0u64; 3];
    for i in (0..120).step_by(7) {
        by_hand[build_frame(&p, i).expect("frame").split as usize] += 1;
    }
    assert_eq!(walked.frame_counts, by_hand);
}

#[test]
fn the_shares_converge() {
    for seed in [0u64, 5, 77, 2024] {
        for shares in SHARE_SETTINGS {
            for n in [1_000u64, 1_234, 10_000] {
                let mut counts = [0u64; 3];
                for i in 0..n {
                    counts[draw_slot(seed, shares, i)] += 1;
                }
                for s in 0..3 {
                    let got = counts[s] as f64 / n as f64;
                    assert!(
                        (got - shares[s]).abs() <= 0.02,
                        "seed {seed}, shares {shares:?}, {n} frames: {counts:?}"
                    );
                }
            }
        }
    }
    // Every full block after the first holds the rounded shares exactly.
    let mut p = swept();
    p.repeats = 80; // 1 920 frames
    assert_eq!(frame_split_counts(&p, 300, u64::MAX), Some([210, 30, 60]));
}

#[test]
fn grouped_splits_fill_every_split_from_their_third_group() {
    // Groups 0, 1, 2 (in frame order for camera poses and sweep points) are
    // one of each split, so a --limit run that reaches three groups has three splits.
    let mut p = swept();
    for seed in [0u64, 1, 2, 3, 11] {
        p.seed = seed;
        for by in [SplitBy::CameraPose, SplitBy::SweepPoint] {
            p.output.split.by = by;
            let g = groups(&p).expect("groups");
            let firsts: std::collections::BTreeSet<usize> =
                (0..3).map(|group| group_slot(&p, group, g)).collect();
            assert_eq!(firsts.len(), 3, "{by:?} seed {seed}");
            let size = p.frame_count() / g;
            let run = run_splits(&p, 2 * size + 1, 1, u64::MAX).expect("walked");
            assert!(run.frame_counts.iter().all(|&n| n > 0), "{run:?}");
            assert_eq!(run.group_counts, [1, 1, 1]);
        }
    }
    // A share under what rounding gives one group still gets one: 4 groups at 70/10/20.
    let mut p = common::tiny_preset();
    p.camera.x = SweepRange::new(-0.2, 0.2, 0.4);
    p.output.split.by = SplitBy::CameraPose;
    let g = groups(&p).expect("groups");
    assert_eq!(g, 4);
    assert_eq!(group_counts(&p, g), [2, 1, 1]);
    let (_, per) = check_groups(&p, "four poses");
    assert_eq!(per, [2, 1, 1]);
}

#[test]
fn too_few_groups_for_the_run_is_a_named_error() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let run = |p: &Preset, args: &[&str]| {
        let file = common::preset_file(tmp.path(), p, "p.ron");
        let out = tmp.path().join("out");
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_swarmshot"))
            .args(["batch".as_ref(), file.as_os_str(), "--out".as_ref()])
            .arg(&out)
            .args(args)
            .output()
            .expect("run swarmshot batch");
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        (o.status.success(), err, out.exists())
    };
    // Sequences of 5 frames: 10 frames hold 2 sequences.
    let p = common::sequence_preset();
    let (ok, err, wrote) = run(&p, &["--limit", "10", "--labels-only"]);
    assert!(!ok && !wrote, "{err}");
    assert!(
        err.contains("a sequence's frames share one split")
            && err.contains("this run's 10 frames hold 2 sequences")
            && err.contains("sequence 0: frames 0–4")
            && err.contains("sequence 1: frames 5–9")
            && err.contains("--limit 11 or more"),
        "{err}"
    );
    // The error alone, not first the warnings of the splits it names.
    let (ok, err, _) = run(&p, &["--limit", "3"]);
    assert!(
        !ok && err.contains("this run's 3 frames hold 1 sequence"),
        "{err}"
    );
    assert!(!err.contains("warning: output.split"), "{err}");
    let (ok, err, _) = run(&p, &["--limit", "10"]);
    assert!(
        !ok && err.contains("this run's 10 frames hold 2 sequences"),
        "{err}"
    );
    // Runs of 1 or 2 frames are let through (warned about); 11 frames hold 3 sequences.
    let (ok, err, _) = run(&p, &["--limit", "2", "--labels-only", "--overwrite"]);
    assert!(ok, "{err}");
    let (ok, err, _) = run(&p, &["--limit", "11", "--labels-only", "--overwrite"]);
    assert!(ok, "{err}");

    // Camera poses of 6 frames: 12 frames hold 2 poses; the preset as a whole is fine.
    let mut p = swept();
    p.output.split.by = SplitBy::CameraPose;
    let (ok, err, _) = run(&p, &["--limit", "12", "--labels-only", "--overwrite"]);
    assert!(!ok, "{err}");
    assert!(
        err.contains("output.split.by: CameraPose keeps each camera pose's frames in one split")
            && err.contains("hold 2 camera poses")
            && err.contains("--limit 13 or more"),
        "{err}"
    );
    // A preset that has too few groups as a whole: `check` says so too.
    let mut p = common::tiny_preset(); // 2 camera poses
    p.output.split.by = SplitBy::CameraPose;
    let file = common::preset_file(tmp.path(), &p, "small.ron");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_swarmshot"))
        .arg("check")
        .arg(&file)
        .output()
        .expect("run swarmshot check");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("hold 2 camera poses") && err.contains("the preset has fewer"),
        "{err}"
    );
    let error =
        swarmshot::pipeline::check::run_split_error(&p, p.frame_count(), 1).expect("an error");
    assert!(error.contains("camera pose 0: frames 0–"), "{error}");
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
