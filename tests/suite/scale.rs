//! Datasets past one process (docs/scale.md): `batch --shard K/N` and
//! `swarmshot merge` give the dataset a single run gives, byte for byte;
//! merge refuses what is not one whole finished run and continues after a
//! kill; a dataset copied elsewhere still names only paths that resolve.
//! Every command runs as a child process, as a user runs it (renders on lavapipe).

use crate::common;
use common::cli::{batch, os};

use std::collections::BTreeSet;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use swarmshot::preset::{LabelFormat, Preset};

const BIN: &str = env!("CARGO_BIN_EXE_swarmshot");

/// 12 frames at 320×180, YOLO and COCO.
fn preset() -> Preset {
    let mut p = common::tiny_preset();
    p.repeats = 3;
    p.output.label_formats = vec![LabelFormat::Yolo, LabelFormat::Coco];
    p
}

fn command(args: &[&std::ffi::OsStr]) -> Command {
    let mut cmd = Command::new(BIN);
    cmd.args(args)
        .env("RUST_BACKTRACE", "0")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    cmd
}

fn run(args: &[&std::ffi::OsStr]) -> Output {
    command(args).output().expect("run swarmshot")
}

fn ok(args: &[&std::ffi::OsStr]) -> String {
    let o = run(args);
    assert!(
        o.status.success(),
        "swarmshot {args:?} failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn err(args: &[&std::ffi::OsStr]) -> String {
    let o = run(args);
    assert!(!o.status.success(), "swarmshot {args:?} should have failed");
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(e.contains("error: "), "not a named error: {e}");
    e
}

fn merge_args<'a>(out: &'a Path, shards: &'a [PathBuf]) -> Vec<&'a std::ffi::OsStr> {
    let mut args = vec![os("merge"), out.as_os_str()];
    args.extend(shards.iter().map(|s| s.as_os_str()));
    args
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
        let (a, b) = (
            std::fs::read(want.join(rel)).expect("read"),
            std::fs::read(got.join(rel)).expect("read"),
        );
        assert!(
            a == b,
            "{what}: {} differs from the single run",
            rel.display()
        );
    }
}

/// Shards 0..n of `preset` into `dir/shard-K`, with `extra` arguments.
fn shards(preset: &Path, dir: &Path, n: u64, extra: &[&str]) -> Vec<PathBuf> {
    (0..n)
        .map(|k| {
            let out = dir.join(format!("shard-{k}"));
            let spec = format!("{k}/{n}");
            let mut args = vec!["--shard", spec.as_str()];
            args.extend(extra);
            batch(preset, &out, &args);
            out
        })
        .collect()
}

#[test]
fn shards_merge_into_the_single_run_byte_for_byte() {
    let tmp = tempfile::tempdir().expect("tempdir");
    for (name, p, n, extra) in [
        ("frames", preset(), 3u64, &[][..]),
        ("limit", preset(), 2, &["--limit", "7"][..]),
        ("sequences", common::sequence_preset(), 3, &[][..]),
    ] {
        let dir = tmp.path().join(name);
        let file = common::preset_file(tmp.path(), &p, &format!("{name}.ron"));
        let single = dir.join("single");
        batch(&file, &single, extra);
        let parts = shards(&file, &dir, n, extra);
        // Each shard holds only its own frames.
        let frames = |d: &Path| {
            std::fs::read_to_string(d.join("manifest.jsonl"))
                .expect("manifest")
                .lines()
                .count()
        };
        let per: Vec<usize> = parts.iter().map(|d| frames(d)).collect();
        assert_eq!(
            per.iter().sum::<usize>(),
            frames(&single),
            "{name}: {per:?}"
        );
        assert!(per.iter().all(|&f| f > 0), "{name}: an empty shard {per:?}");
        // Given in any order.
        let mut given = parts.clone();
        given.reverse();
        let out = dir.join("merged");
        let said = ok(&merge_args(&out, &given));
        assert!(said.contains(&format!("merged {n} shards")), "{said}");
        assert_same_dataset(&single, &out, name);
        // Images are hard links to the shards' (same file system here).
        let img = common::files_under(&out)
            .into_iter()
            .find(|p| p.starts_with("images"))
            .expect("an image");
        let inode = |d: &Path| std::fs::metadata(d.join(&img)).expect("stat").ino();
        assert!(
            parts
                .iter()
                .any(|s| s.join(&img).exists() && inode(s) == inode(&out)),
            "{name}: {} is not a hard link to a shard's",
            img.display()
        );
        // The merged folder is a finished run of the preset: the batch finds nothing to do.
        let before = std::fs::read(out.join("manifest.jsonl")).expect("manifest");
        batch(&file, &out, extra);
        assert_eq!(
            before,
            std::fs::read(out.join("manifest.jsonl")).expect("manifest")
        );
        // Merging again continues a finished merge: nothing changes.
        ok(&merge_args(&out, &parts));
        assert_same_dataset(&single, &out, name);
    }
}

#[test]
fn merge_refuses_what_is_not_one_whole_finished_run() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = preset();
    let file = common::preset_file(tmp.path(), &p, "p.ron");
    let parts = shards(&file, tmp.path(), 3, &["--limit", "6"]);
    let out = tmp.path().join("out");

    let e = err(&merge_args(&out, &parts[..2]));
    assert!(e.contains("shard 2/3 is missing"), "{e}");
    let twice = vec![
        parts[0].clone(),
        parts[1].clone(),
        parts[1].clone(),
        parts[2].clone(),
    ];
    let e = err(&merge_args(&out, &twice));
    assert!(e.contains("both shard 1/3") && e.contains("overlap"), "{e}");

    // Another preset's shard.
    let mut other = p.clone();
    other.seed = 8;
    let other_file = common::preset_file(tmp.path(), &other, "other.ron");
    let foreign = tmp.path().join("foreign");
    batch(&other_file, &foreign, &["--limit", "6", "--shard", "2/3"]);
    let mixed = vec![parts[0].clone(), parts[1].clone(), foreign.clone()];
    let e = err(&merge_args(&out, &mixed));
    assert!(
        e.contains("different runs") && e.contains("preset.lock.ron"),
        "{e}"
    );
    // Another frame count, another shard count.
    let longer = tmp.path().join("longer");
    batch(&file, &longer, &["--limit", "9", "--shard", "2/3"]);
    let e = err(&merge_args(
        &out,
        &[parts[0].clone(), parts[1].clone(), longer],
    ));
    assert!(e.contains("--limit differs"), "{e}");
    let halves = tmp.path().join("halves");
    batch(&file, &halves, &["--limit", "6", "--shard", "1/2"]);
    let e = err(&merge_args(&out, &[parts[0].clone(), halves]));
    assert!(e.contains("cut in 3 and 2 shards"), "{e}");

    // A whole run is not a shard.
    let whole = tmp.path().join("whole");
    batch(&file, &whole, &["--limit", "6"]);
    let e = err(&merge_args(&out, &[whole]));
    assert!(e.contains("made without --shard"), "{e}");

    // An unfinished shard: its ledger without the final mark.
    let unfinished = tmp.path().join("unfinished");
    copy_dir(&parts[2], &unfinished);
    let ledger = unfinished.join(".swarmshot-ledger");
    let text = std::fs::read_to_string(&ledger).expect("ledger");
    std::fs::write(&ledger, text.replace("!done\n", "")).expect("ledger");
    let e = err(&merge_args(
        &out,
        &[parts[0].clone(), parts[1].clone(), unfinished],
    ));
    assert!(
        e.contains("shard 2/3 is incomplete") && e.contains("--shard 2/3"),
        "{e}"
    );

    // OUT is a shard.
    let e = err(&merge_args(&parts[0], &parts));
    assert!(e.contains("is one of the shards"), "{e}");
    assert!(!out.exists(), "a refused merge created its output folder");

    // A shard folder belongs to its shard: another shard, or no shard, is refused.
    for extra in [
        &["--limit", "6", "--shard", "1/3"][..],
        &["--limit", "6"][..],
    ] {
        let mut args = vec![
            os("batch"),
            file.as_os_str(),
            os("--out"),
            parts[0].as_os_str(),
        ];
        args.extend(extra.iter().map(os));
        let e = err(&args);
        assert!(
            e.contains("shard 0/3") && e.contains("--shard differs"),
            "{e}"
        );
    }
    // The same shard again, with or without --resume, finds nothing to do.
    batch(
        &file,
        &parts[0],
        &["--limit", "6", "--shard", "0/3", "--resume"],
    );

    // Bad --shard values are named before anything is written.
    for (value, want) in [
        ("3/3", "K must be below N"),
        ("x", "expected K/N"),
        ("auto", "neither SLURM_ARRAY_TASK_ID"),
        ("auto/0", "N must be at least 1"),
    ] {
        let fresh = tmp.path().join("never");
        let e = err(&[
            os("batch"),
            file.as_os_str(),
            os("--out"),
            fresh.as_os_str(),
            os("--shard"),
            os(value),
        ]);
        assert!(e.contains(want), "{value}: {e}");
        assert!(!fresh.exists());
    }
    // JOB_COMPLETION_INDEX without the count, and Slurm variables that disagree.
    let fresh = tmp.path().join("never");
    let o = command(&[
        os("batch"),
        file.as_os_str(),
        os("--out"),
        fresh.as_os_str(),
        os("--shard"),
        os("auto"),
    ])
    .env("JOB_COMPLETION_INDEX", "1")
    .output()
    .expect("run");
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("--shard auto/N"), "{e}");
    let o = command(&[
        os("batch"),
        file.as_os_str(),
        os("--out"),
        fresh.as_os_str(),
        os("--shard"),
        os("auto/4"),
    ])
    .env("SLURM_ARRAY_TASK_ID", "1")
    .env("SLURM_ARRAY_TASK_MIN", "0")
    .env("SLURM_ARRAY_TASK_MAX", "2")
    .env("SLURM_ARRAY_TASK_COUNT", "3")
    .output()
    .expect("run");
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && e.contains("array has 3 tasks"),
        "{e}"
    );
    assert!(!fresh.exists());
}

fn copy_dir(from: &Path, to: &Path) {
    for rel in common::files_under(from) {
        let dest = to.join(&rel);
        std::fs::create_dir_all(dest.parent().expect("parent")).expect("mkdir");
        std::fs::copy(from.join(&rel), &dest).expect("copy");
    }
}

/// Wait until `ready` holds (or the child exits), then SIGKILL the child.
fn kill_when(mut child: Child, what: &str, ready: impl Fn() -> bool) {
    let t = Instant::now();
    while !ready() {
        if let Some(status) = child.try_wait().expect("try_wait") {
            panic!("it ended ({status}) before the kill point {what}");
        }
        assert!(
            t.elapsed() < Duration::from_secs(240),
            "kill point {what} never came"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().expect("SIGKILL");
    child.wait().expect("wait");
}

#[test]
fn a_killed_merge_or_shard_continues_to_the_same_bytes() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = common::preset_file(tmp.path(), &preset(), "p.ron");
    let single = tmp.path().join("single");
    batch(&file, &single, &[]);
    // Shard 1/3 (frames 4..8) killed before frame 5's checkpoint, then continued.
    let parts: Vec<PathBuf> = (0..3)
        .map(|k| tmp.path().join(format!("shard-{k}")))
        .collect();
    batch(&file, &parts[0], &["--shard", "0/3"]);
    batch(&file, &parts[2], &["--shard", "2/3"]);
    let args = [
        os("batch"),
        file.as_os_str(),
        os("--out"),
        parts[1].as_os_str(),
        os("--shard"),
        os("1/3"),
    ];
    let child = command(&args)
        .env("SWARMSHOT_STALL_AT", "checkpoint:5")
        .spawn()
        .expect("spawn");
    let ledger = parts[1].join(".swarmshot-ledger");
    kill_when(child, "shard checkpoint:5", || {
        std::fs::read_to_string(&ledger).is_ok_and(|t| t.matches("\n=").count() == 1)
            && std::fs::read_to_string(parts[1].join("manifest.jsonl"))
                .is_ok_and(|m| m.lines().count() == 2)
    });
    let e = err(&merge_args(&tmp.path().join("early"), &parts));
    assert!(e.contains("shard 1/3 is incomplete"), "{e}");
    batch(&file, &parts[1], &["--shard", "1/3", "--resume"]);

    // The merge killed before shard 0's checkpoint, then after it (on a file of shard 1).
    let out = tmp.path().join("merged");
    let child = command(&merge_args(&out, &parts))
        .env("SWARMSHOT_STALL_AT", "checkpoint:3")
        .spawn()
        .expect("spawn");
    let want = std::fs::read(parts[0].join("manifest.jsonl")).expect("manifest");
    kill_when(child, "merge checkpoint:3", || {
        std::fs::read(out.join("manifest.jsonl")).is_ok_and(|m| m.len() == want.len())
    });
    let shard1_image = common::files_under(&parts[1])
        .into_iter()
        .find(|p| p.starts_with("images"))
        .expect("an image of shard 1");
    let tmp_name = shard1_image.with_file_name(format!(
        ".{}.tmp",
        shard1_image.file_name().expect("name").to_string_lossy()
    ));
    let child = command(&merge_args(&out, &parts))
        .env("SWARMSHOT_STALL_AT", shard1_image.to_str().expect("utf-8"))
        .spawn()
        .expect("spawn");
    kill_when(child, "merge at a shard 1 image", || {
        out.join(&tmp_name).exists()
    });
    let said = ok(&merge_args(&out, &parts));
    assert!(
        said.contains("1 joined by an earlier, interrupted merge"),
        "{said}"
    );
    assert_same_dataset(&single, &out, "merge killed twice");
    let listed: BTreeSet<String> = std::fs::read_to_string(out.join(".swarmshot-ledger"))
        .expect("ledger")
        .lines()
        .filter_map(|l| l.strip_prefix('*').or_else(|| l.strip_prefix('+')))
        .map(str::to_owned)
        .collect();
    for rel in common::files_under(&out) {
        let rel = rel.to_string_lossy().into_owned();
        assert!(
            rel == ".swarmshot-ledger" || listed.contains(&rel),
            "{rel} is not in the merged folder's ledger"
        );
    }
}

#[test]
fn a_preset_named_from_any_folder_locks_the_same_run() {
    // A model's relative path was locked as resolved against the preset's
    // folder as the command line named it (`presets/../m/cf2.glb`,
    // `/abs/presets/../m/cf2.glb`): the lock's bytes and the run's hash
    // depended on the folder the command ran in, so shards made from two
    // folders were refused by merge, and a resume from another folder was
    // refused as "a different preset". The lock now holds the path as the
    // preset file wrote it.
    let tmp = tempfile::tempdir().expect("tempdir");
    let root = std::fs::canonicalize(tmp.path()).expect("canonical");
    std::fs::create_dir_all(root.join("m")).expect("mkdir");
    std::fs::create_dir_all(root.join("presets")).expect("mkdir");
    let model = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/uav/crazyflie2_cf2/cf2.glb"
    );
    std::fs::copy(model, root.join("m/cf2.glb")).expect("copy the model");
    let mut p = preset();
    p.models[0].source = swarmshot::preset::ModelSource::File(PathBuf::from("../m/cf2.glb"));
    let file = common::preset_file(&root.join("presets"), &p, "p.ron");
    let single = root.join("single");
    batch(&file, &single, &[]);
    let lock = std::fs::read_to_string(single.join("preset.lock.ron")).expect("lock");
    assert!(lock.contains("File(\"../m/cf2.glb\")"), "{lock}");
    let in_folder = |cwd: &Path, args: &[&str]| {
        let o = command(&args.iter().map(os).collect::<Vec<_>>())
            .current_dir(cwd)
            .output()
            .expect("run swarmshot");
        assert!(
            o.status.success(),
            "swarmshot {args:?} in {} failed:\n{}",
            cwd.display(),
            String::from_utf8_lossy(&o.stderr)
        );
    };
    in_folder(
        &root,
        &[
            "batch",
            "presets/p.ron",
            "--out",
            "s/shard-0",
            "--shard",
            "0/2",
        ],
    );
    in_folder(
        &root.join("presets"),
        &["batch", "p.ron", "--out", "../s/shard-1", "--shard", "1/2"],
    );
    let parts = [root.join("s/shard-0"), root.join("s/shard-1")];
    let merged = root.join("merged");
    ok(&merge_args(&merged, &parts));
    assert_same_dataset(&single, &merged, "shards made from two folders");
    // The finished single run, named from another folder, is the same run.
    in_folder(
        &root.join("m"),
        &["batch", "../presets/p.ron", "--out", "../single"],
    );
}

#[test]
fn a_copied_dataset_names_only_paths_that_resolve() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = common::preset_file(tmp.path(), &common::sequence_preset(), "p.ron");
    let made = tmp.path().join("made-here");
    batch(&file, &made, &[]);
    let moved = tmp.path().join("elsewhere/moved");
    std::fs::create_dir(tmp.path().join("elsewhere")).expect("mkdir");
    // As a user copies it (empty split folders included).
    let cp = Command::new("cp")
        .arg("-a")
        .arg(&made)
        .arg(&moved)
        .status()
        .expect("cp");
    assert!(cp.success());
    let old = std::fs::canonicalize(&made).expect("canonical");
    std::fs::remove_dir_all(&made).expect("remove the original");
    let old = old.to_string_lossy().into_owned();
    for rel in common::files_under(&moved) {
        let bytes = std::fs::read(moved.join(&rel)).expect("read");
        assert!(
            !String::from_utf8_lossy(&bytes).contains(&old),
            "{} names the folder it was made in",
            rel.display()
        );
    }
    // data.yaml: no `path`, so Ultralytics takes its folder as the root.
    let yaml = std::fs::read_to_string(moved.join("data.yaml")).expect("data.yaml");
    let mut splits = 0;
    for line in yaml.lines() {
        assert!(!line.starts_with("path:"), "{yaml}");
        for key in ["train: ", "val: ", "test: "] {
            if let Some(dir) = line.strip_prefix(key) {
                assert!(moved.join(dir).is_dir(), "{dir} does not resolve");
                splits += 1;
            }
        }
    }
    // train and val always; test unless it is empty (an empty split is never named).
    assert!(
        (2..=3).contains(&splits) && yaml.contains("\ntrain: ") && yaml.contains("\nval: "),
        "{yaml}"
    );
    // COCO file_name under images/, manifest image under the folder.
    let mut named = 0;
    for split in ["train", "val", "test"] {
        let coco: serde_json::Value = serde_json::from_slice(
            &std::fs::read(moved.join(format!("annotations/instances_{split}.json")))
                .expect("coco"),
        )
        .expect("coco parses");
        for img in coco["images"].as_array().expect("images") {
            let name = img["file_name"].as_str().expect("file_name");
            assert!(!Path::new(name).is_absolute());
            assert!(moved.join("images").join(name).is_file(), "{name}");
            named += 1;
        }
    }
    let manifest = std::fs::read_to_string(moved.join("manifest.jsonl")).expect("manifest");
    for line in manifest.lines() {
        let v: serde_json::Value = serde_json::from_str(line).expect("line");
        let image = v["image"].as_str().expect("image");
        assert!(moved.join(image).is_file(), "{image}");
    }
    assert_eq!(named, manifest.lines().count());
    // MOT: imDir is relative to the sequence's folder, its frames numbered from 1.
    let mut sequences = 0;
    for rel in common::files_under(&moved) {
        if rel.file_name().is_some_and(|n| n == "seqinfo.ini") {
            let ini = std::fs::read_to_string(moved.join(&rel)).expect("seqinfo");
            let field = |k: &str| {
                ini.lines()
                    .find_map(|l| l.strip_prefix(k))
                    .unwrap_or_else(|| panic!("{k} missing"))
                    .to_owned()
            };
            let seq_dir = moved.join(rel.parent().expect("parent"));
            let im_dir = seq_dir.join(field("imDir="));
            let len: u64 = field("seqLength=").parse().expect("seqLength");
            for t in 1..=len {
                let image = im_dir.join(format!("{t:06}{}", field("imExt=")));
                assert!(image.is_file(), "{} does not resolve", image.display());
            }
            sequences += 1;
        }
    }
    assert_eq!(sequences, 3);
}
