//! Output you can trust (docs/reliability.md): `swarmshot batch` as a child
//! process killed with SIGKILL at several points and resumed, a write error
//! from a file-size limit, symbolic links in the output folder, and user
//! files next to a dataset. Every resumed dataset is compared byte for byte
//! with an uninterrupted run.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use swarmshot::preset::{ImageFormat, LabelFormat, Preset};

const BIN: &str = env!("CARGO_BIN_EXE_swarmshot");

/// 320×180 JPEG frames, YOLO and COCO, 48 frames: big enough to kill mid-way.
fn preset() -> Preset {
    let mut p = common::tiny_preset();
    p.repeats = 12;
    p.output.image_format = ImageFormat::Jpeg { quality: 85 };
    p.output.label_formats = vec![LabelFormat::Yolo, LabelFormat::Coco];
    p
}

fn batch_cmd(preset: &Path, out: &Path, extra: &[&str]) -> Command {
    let mut cmd = Command::new(BIN);
    cmd.arg("batch")
        .arg(preset)
        .arg("--out")
        .arg(out)
        .args(extra)
        .env("RUST_BACKTRACE", "0")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    cmd
}

fn run(preset: &Path, out: &Path, extra: &[&str]) -> Output {
    batch_cmd(preset, out, extra)
        .output()
        .expect("run swarmshot")
}

fn run_ok(preset: &Path, out: &Path, extra: &[&str]) {
    let o = run(preset, out, extra);
    assert!(
        o.status.success(),
        "swarmshot batch {extra:?} failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn run_err(preset: &Path, out: &Path, extra: &[&str]) -> String {
    let o = run(preset, out, extra);
    assert!(
        !o.status.success(),
        "swarmshot batch {extra:?} should have failed"
    );
    String::from_utf8_lossy(&o.stderr).into_owned()
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
    let fw: Vec<_> = common::files_under(want)
        .into_iter()
        .filter(|p| p != ledger)
        .collect();
    let fg: Vec<_> = common::files_under(got)
        .into_iter()
        .filter(|p| p != ledger)
        .collect();
    assert_eq!(fw, fg, "{what}: file lists differ");
    for rel in &fw {
        assert!(
            bytes(want, rel) == bytes(got, rel),
            "{what}: {} differs from the uninterrupted run",
            rel.display()
        );
    }
}

/// Wait until `ready` holds (or the child exits), then SIGKILL the child.
fn kill_when(mut child: Child, what: &str, ready: impl Fn() -> bool) {
    let t = Instant::now();
    loop {
        if ready() {
            break;
        }
        if let Some(status) = child.try_wait().expect("try_wait") {
            panic!("the batch ended ({status}) before the kill point {what}");
        }
        assert!(
            t.elapsed() < Duration::from_secs(240),
            "kill point {what} never came"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().expect("SIGKILL"); // std's kill is SIGKILL on Unix
    child.wait().expect("wait");
}

fn count_files(dir: &Path) -> usize {
    std::fs::read_dir(dir).map_or(0, |d| d.count())
}

/// Every image has its label and the reverse, the manifest has one whole
/// line per image, and no temporary file is left.
fn assert_complete_pairs(dir: &Path) -> usize {
    let files = common::files_under(dir);
    let stems = |top: &str, ext: &str| -> Vec<String> {
        let mut v: Vec<String> = files
            .iter()
            .filter(|p| p.starts_with(top))
            .map(|p| {
                let s = p.strip_prefix(top).expect("prefix").to_string_lossy();
                s.strip_suffix(ext)
                    .unwrap_or_else(|| panic!("unexpected file {}", p.display()))
                    .to_owned()
            })
            .collect();
        v.sort();
        v
    };
    let images = stems("images", ".jpg");
    assert_eq!(images, stems("labels", ".txt"), "images and labels differ");
    for p in &files {
        assert!(
            !p.to_string_lossy().ends_with(".tmp"),
            "temporary file left: {}",
            p.display()
        );
    }
    let manifest = std::fs::read_to_string(dir.join("manifest.jsonl")).expect("manifest");
    assert!(
        manifest.is_empty() || manifest.ends_with('\n'),
        "torn manifest"
    );
    for line in manifest.lines() {
        serde_json::from_str::<serde_json::Value>(line).expect("whole manifest line");
    }
    assert_eq!(manifest.lines().count(), images.len());
    images.len()
}

#[test]
fn sigkill_at_any_point_then_resume_is_byte_identical() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = preset();
    let file = common::preset_file(tmp.path(), &p, "p.ron");
    let reference = tmp.path().join("reference");
    run_ok(&file, &reference, &[]);
    assert_eq!(
        count_files(&reference.join("images/train"))
            + count_files(&reference.join("images/val"))
            + count_files(&reference.join("images/test")),
        p.frame_count() as usize
    );
    // A label file of a frame in the middle, and the second COCO file.
    let mid_label = {
        let manifest = std::fs::read_to_string(reference.join("manifest.jsonl")).expect("manifest");
        let line: serde_json::Value =
            serde_json::from_str(manifest.lines().nth(20).expect("line 20")).expect("json");
        format!(
            "labels/{}/00000020.txt",
            line["split"].as_str().expect("split")
        )
    };
    let images = |dir: &Path| {
        ["train", "val", "test"]
            .iter()
            .map(|s| count_files(&dir.join("images").join(s)))
            .sum::<usize>()
    };

    // After N images exist (any point inside the frame loop).
    for n in [1usize, 9, 30] {
        let out = tmp.path().join(format!("killed-after-{n}"));
        let child = batch_cmd(&file, &out, &[]).spawn().expect("spawn");
        kill_when(child, &format!("{n} images"), || images(&out) >= n);
        run_ok(&file, &out, &["--resume"]);
        assert_same_dataset(&reference, &out, &format!("killed after {n} images"));
    }

    // Between a frame's image and its label (the label's temporary file is
    // written, not yet renamed): the image stands alone until the resume.
    {
        let out = tmp.path().join("killed-before-label");
        let child = batch_cmd(&file, &out, &[])
            .env("SWARMSHOT_STALL_AT", &mid_label)
            .spawn()
            .expect("spawn");
        let tmp_label = out.join(mid_label.replace("00000020.txt", ".00000020.txt.tmp"));
        kill_when(child, "before a label's rename", || tmp_label.exists());
        assert!(!out.join(&mid_label).exists());
        // Rerunning the same command (no --resume) also continues.
        run_ok(&file, &out, &[]);
        assert_same_dataset(&reference, &out, "killed before a label");
    }

    // After a frame's manifest line and COCO records, before its checkpoint:
    // the resume must cut them back.
    {
        let out = tmp.path().join("killed-before-checkpoint");
        let child = batch_cmd(&file, &out, &[])
            .env("SWARMSHOT_STALL_AT", "checkpoint:20")
            .spawn()
            .expect("spawn");
        let manifest = out.join("manifest.jsonl");
        kill_when(child, "before a checkpoint", || {
            std::fs::read_to_string(&manifest).is_ok_and(|m| m.lines().count() == 21)
        });
        run_ok(&file, &out, &["--resume"]);
        assert_same_dataset(&reference, &out, "killed before a checkpoint");
    }

    // During COCO writing (the splits' files are written side by side, then
    // renamed in turn): instances_train.json is in place, instances_val.json
    // is written under its temporary name, not yet renamed.
    {
        let out = tmp.path().join("killed-in-coco");
        let barrier = tmp.path().join("coco-barrier");
        let child = batch_cmd(&file, &out, &[])
            .env("SWARMSHOT_STALL_AT", "annotations/instances_val.json")
            .env("SWARMSHOT_STALL_UNTIL", &barrier)
            .spawn()
            .expect("spawn");
        let stalled = barrier.with_extension("stalled");
        kill_when(child, "during COCO writing", || stalled.exists());
        assert!(out.join("annotations/instances_train.json").exists());
        assert!(out.join("annotations/.instances_val.json.tmp").exists());
        assert!(!out.join("annotations/instances_val.json").exists());
        assert!(!out.join("stats.json").exists());
        run_ok(&file, &out, &["--resume"]);
        assert_same_dataset(&reference, &out, "killed during COCO writing");
    }

    // A finished run, rerun with or without --resume, writes nothing.
    let stamps = |dir: &Path| -> Vec<(PathBuf, std::time::SystemTime)> {
        common::files_under(dir)
            .into_iter()
            .map(|r| {
                let t = std::fs::symlink_metadata(dir.join(&r))
                    .and_then(|m| m.modified())
                    .expect("mtime");
                (r, t)
            })
            .collect()
    };
    let before = stamps(&reference);
    run_ok(&file, &reference, &[]);
    run_ok(&file, &reference, &["--resume"]);
    assert_eq!(
        stamps(&reference),
        before,
        "a finished run was written again"
    );
}

#[test]
fn write_error_stops_at_once_leaves_complete_frames_and_resumes() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let mut p = preset();
    // COCO's record parts grow beside the manifest; without them the
    // manifest is the one file that outgrows the limit.
    p.output.label_formats = vec![LabelFormat::Yolo];
    let file = common::preset_file(tmp.path(), &p, "p.ron");
    let reference = tmp.path().join("reference");
    run_ok(&file, &reference, &[]);
    // A file-size limit the manifest outgrows half-way, and nothing else does.
    let manifest_len = std::fs::metadata(reference.join("manifest.jsonl"))
        .expect("manifest")
        .len();
    let limit_kib = manifest_len / 2 / 1024;
    for rel in common::files_under(&reference) {
        if rel != Path::new("manifest.jsonl") {
            let len = std::fs::metadata(reference.join(&rel)).expect("meta").len();
            assert!(
                len < limit_kib * 1024,
                "{} ({len} bytes) would hit the limit first",
                rel.display()
            );
        }
    }
    let out = tmp.path().join("limited");
    // bash's `ulimit -f` counts 1024-byte blocks; ignoring SIGXFSZ (inherited
    // through exec) turns the kernel's kill into an EFBIG write error.
    let o = Command::new("bash")
        .arg("-c")
        .arg(format!(
            "trap '' XFSZ; ulimit -f {limit_kib}; exec \"$0\" batch \"$1\" --out \"$2\""
        ))
        .arg(BIN)
        .arg(&file)
        .arg(&out)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("run bash");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "the limited batch should fail");
    assert!(
        stderr.contains("manifest.jsonl") && stderr.contains("File too large"),
        "the error must name the file and the cause:\n{stderr}"
    );
    assert!(stderr.contains("--resume"), "{stderr}");
    let done = assert_complete_pairs(&out);
    assert!(
        done > 0 && (done as u64) < p.frame_count(),
        "{done} frames survived"
    );
    // Stopped at once: no frame was made past the one that failed (the ledger
    // names at most the frames written plus the one in flight).
    let ledger = std::fs::read_to_string(out.join(".swarmshot-ledger")).expect("ledger");
    let claimed = ledger.lines().filter(|l| l.starts_with("+images/")).count();
    assert!(claimed <= done + 1, "{claimed} images claimed, {done} done");
    run_ok(&file, &out, &["--resume"]);
    assert_same_dataset(&reference, &out, "resumed after a write error");
}

#[test]
fn symlinks_in_the_output_folder_are_never_followed() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let mut p = preset();
    p.repeats = 1;
    let file = common::preset_file(tmp.path(), &p, "p.ron");
    let outside = tmp.path().join("outside");
    std::fs::create_dir(&outside).expect("mkdir");
    for name in [
        "data.yaml",
        "manifest.jsonl",
        "stats.json",
        "preset.lock.ron",
        ".swarmshot-ledger",
        "images",
        "annotations",
    ] {
        let out = tmp.path().join(format!("with-link-{name}"));
        std::fs::create_dir(&out).expect("mkdir");
        let target = outside.join(name);
        std::os::unix::fs::symlink(&target, out.join(name)).expect("symlink");
        for flags in [&[][..], &["--overwrite"][..]] {
            let err = run_err(&file, &out, flags);
            assert!(
                err.contains(name) && (err.contains("symbolic link") || err.contains("not empty")),
                "{name} {flags:?}: {err}"
            );
        }
        assert!(
            std::fs::symlink_metadata(&target).is_err(),
            "{name}: something was created through the link"
        );
        assert_eq!(common::files_under(&outside), Vec::<PathBuf>::new());
        assert_eq!(
            common::files_under(&out),
            vec![PathBuf::from(name)],
            "{name}"
        );
    }

    // A link at a frame's image in an interrupted run: refused, not followed.
    let out = tmp.path().join("interrupted");
    run_ok(&file, &out, &[]);
    let manifest = std::fs::read_to_string(out.join("manifest.jsonl")).expect("manifest");
    let last: serde_json::Value =
        serde_json::from_str(manifest.lines().last().expect("a line")).expect("json");
    let img = out.join(last["image"].as_str().expect("image"));
    std::fs::remove_file(&img).expect("rm");
    let target = outside.join("stolen.jpg");
    std::os::unix::fs::symlink(&target, &img).expect("symlink");
    // Make it a run killed in its last frame: drop the last checkpoint and
    // the "done" mark from the ledger.
    let ledger = std::fs::read_to_string(out.join(".swarmshot-ledger")).expect("ledger");
    let lines: Vec<&str> = ledger.lines().collect();
    let last_commit = lines
        .iter()
        .rposition(|l| l.starts_with('='))
        .expect("checkpoint");
    let kept: String = lines
        .iter()
        .enumerate()
        .filter(|&(i, l)| i != last_commit && *l != "!done")
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    std::fs::write(out.join(".swarmshot-ledger"), kept).expect("cut ledger");
    let err = run_err(&file, &out, &["--resume"]);
    assert!(err.contains("symbolic link"), "{err}");
    assert!(std::fs::symlink_metadata(&target).is_err());
    assert_eq!(common::files_under(&outside), Vec::<PathBuf>::new());
}

#[test]
fn user_files_survive_with_and_without_overwrite() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let mut p = preset();
    p.repeats = 2;
    let file = common::preset_file(tmp.path(), &p, "p.ron");
    let out = tmp.path().join("shared");
    let mine = [
        "notes.txt",
        "images/mine.jpg",
        "images/train/holiday.jpg",
        "labels/train/holiday.txt",
        "annotations/mine.json",
    ];
    for rel in mine {
        let path = out.join(rel);
        std::fs::create_dir_all(path.parent().expect("parent")).expect("mkdir");
        std::fs::write(&path, rel).expect("write");
    }
    let kept = |what: &str| {
        for rel in mine {
            assert_eq!(
                std::fs::read_to_string(out.join(rel)).unwrap_or_default(),
                rel,
                "{what}: {rel} was touched"
            );
        }
    };
    // A foreign folder: refused without --overwrite, shared with it.
    let err = run_err(&file, &out, &[]);
    assert!(
        err.contains("not empty") && err.contains("--overwrite"),
        "{err}"
    );
    kept("refused");
    run_ok(&file, &out, &["--overwrite"]);
    kept("first --overwrite");
    let full = assert_dataset_frames(&out);
    assert_eq!(full, p.frame_count() as usize);

    // A peek with --limit 2 neither wipes nor joins the full dataset.
    let err = run_err(&file, &out, &["--limit", "2"]);
    assert!(
        err.contains("--limit") && err.contains("--overwrite"),
        "{err}"
    );
    assert_eq!(assert_dataset_frames(&out), full);
    // Another preset: refused, and with --overwrite only the run's own files go.
    let mut other = p.clone();
    other.seed += 1;
    let other_file = common::preset_file(tmp.path(), &other, "other.ron");
    let err = run_err(&other_file, &out, &[]);
    assert!(err.contains("different preset"), "{err}");
    let err = run_err(&other_file, &out, &["--resume"]);
    assert!(err.contains("different preset"), "{err}");
    run_ok(&other_file, &out, &["--overwrite", "--limit", "3"]);
    kept("second --overwrite");
    assert_eq!(assert_dataset_frames(&out), 3);
    // The folder is now exactly the new run plus the user's files.
    let solo = tmp.path().join("solo");
    run_ok(&other_file, &solo, &["--limit", "3"]);
    let mut expected: Vec<PathBuf> = common::files_under(&solo);
    expected.extend(mine.iter().map(PathBuf::from));
    expected.sort();
    assert_eq!(common::files_under(&out), expected);
}

#[test]
fn a_user_file_at_a_frame_name_is_refused_not_replaced() {
    // A file of the user's where a frame's image or label (or a plan's
    // label) will be written: refused by name before anything is written,
    // with --overwrite, by a rendered run, a plan and --resume; never
    // replaced, never listed in the ledger.
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = preset();
    let file = common::preset_file(tmp.path(), &p, "p.ron");
    let reference = tmp.path().join("reference");
    run_ok(&file, &reference, &[]);
    // Frame `i`'s image and label, as the reference run wrote them.
    let of = |i: u64| {
        let stem = format!("{i:08}.");
        let files = common::files_under(&reference);
        let find = |top: &str| {
            (files.iter())
                .find(|f| f.starts_with(top) && f.to_string_lossy().contains(&stem))
                .expect("frame file")
                .to_string_lossy()
                .into_owned()
        };
        (find("images"), find("labels"))
    };
    let (image0, label0) = of(0);
    let plant = |out: &Path, rel: &str| {
        let mine = out.join(rel);
        std::fs::create_dir_all(mine.parent().expect("parent")).expect("mkdir");
        std::fs::write(&mine, "precious").expect("write");
    };
    let untouched = |out: &Path, rel: &str, what: &str| {
        assert_eq!(
            std::fs::read_to_string(out.join(rel)).expect("kept"),
            "precious",
            "{what}"
        );
        let ledger = std::fs::read_to_string(out.join(".swarmshot-ledger")).unwrap_or_default();
        assert!(!ledger.contains(rel), "{what}: claimed as ours:\n{ledger}");
    };
    for (name, rel, extra) in [
        ("image", &image0, &["--overwrite"][..]),
        ("label", &label0, &["--overwrite"][..]),
        ("plan", &label0, &["--overwrite", "--labels-only"][..]),
    ] {
        let out = tmp.path().join(name);
        plant(&out, rel);
        let err = run_err(&file, &out, extra);
        assert!(
            err.contains(rel.as_str()) && err.contains("not written by swarmshot"),
            "{name}: {err}"
        );
        untouched(&out, rel, name);
    }
    // A run killed at frame 1's checkpoint, then a user file at frame 2's
    // image: --resume refuses it before writing anything, and once the file
    // is moved away finishes the dataset the reference run made.
    let out = tmp.path().join("resumed");
    let (image1, _) = of(1);
    let child = (batch_cmd(&file, &out, &[]).env("SWARMSHOT_STALL_AT", "checkpoint:1"))
        .spawn()
        .expect("spawn");
    kill_when(child, "frame 1's checkpoint", || out.join(&image1).exists());
    let (image2, _) = of(2);
    plant(&out, &image2);
    let err = run_err(&file, &out, &["--resume"]);
    assert!(
        err.contains(image2.as_str()) && err.contains("not written by swarmshot"),
        "{err}"
    );
    untouched(&out, &image2, "resume");
    std::fs::remove_file(out.join(&image2)).expect("moved away");
    run_ok(&file, &out, &["--resume"]);
    assert_same_dataset(&reference, &out, "resumed after the user's file moved");
}

/// The 2-repeat preset written to `dir/p.ron` and run to its end twice, into
/// `dir/reference` (left alone) and `dir/out` (the run a test damages).
fn two_finished_runs(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let mut p = preset();
    p.repeats = 2;
    let file = common::preset_file(dir, &p, "p.ron");
    let (reference, out) = (dir.join("reference"), dir.join("out"));
    run_ok(&file, &reference, &[]);
    run_ok(&file, &out, &[]);
    (file, reference, out)
}

#[test]
fn an_overwrite_killed_while_deleting_never_leaves_a_finished_looking_run() {
    // `--overwrite` deletes the earlier run's files, then its ledger. Killed
    // in between, the folder held the old ledger with every checkpoint and
    // its done mark: the same command without --overwrite said "already
    // complete" over a folder whose files were gone. The ledger now forgets
    // the run's progress before the first file is deleted.
    let tmp = tempfile::tempdir().expect("tempdir");
    let (file, reference, out) = two_finished_runs(tmp.path());
    let child = batch_cmd(&file, &out, &["--overwrite"])
        .env("SWARMSHOT_STALL_AT", "overwrite:deleting")
        .spawn()
        .expect("spawn");
    kill_when(child, "the first file deleted", || {
        !out.join("preset.lock.ron").exists()
    });
    let ledger = std::fs::read_to_string(out.join(".swarmshot-ledger")).expect("ledger");
    assert!(
        !ledger.contains("!done") && !ledger.contains("\n="),
        "a half-deleted run still looks finished:\n{ledger}"
    );
    run_ok(&file, &out, &[]);
    assert_same_dataset(&reference, &out, "the run after a killed --overwrite");
}

#[test]
fn a_finished_run_missing_files_is_not_called_complete() {
    // A finished run's files deleted or cut after it ended: the same command
    // said "already complete" and wrote nothing. It now names what changed
    // and writes nothing; --overwrite makes the run again.
    let tmp = tempfile::tempdir().expect("tempdir");
    let (file, reference, out) = two_finished_runs(tmp.path());
    let image = common::files_under(&out.join("images/train"))
        .into_iter()
        .next()
        .expect("a train image");
    let image = Path::new("images/train").join(image);
    std::fs::remove_file(out.join(&image)).expect("delete an image");
    std::fs::remove_file(out.join("stats.json")).expect("delete stats");
    let manifest = std::fs::OpenOptions::new()
        .write(true)
        .open(out.join("manifest.jsonl"))
        .expect("manifest");
    manifest.set_len(100).expect("cut the manifest");
    for extra in [&[][..], &["--resume"][..]] {
        let err = run_err(&file, &out, extra);
        assert!(
            err.contains("finished run")
                && err.contains(&format!("{} is missing", image.display()))
                && err.contains("stats.json is missing")
                && err.contains("manifest.jsonl is 100 bytes")
                && err.contains("--overwrite"),
            "{err}"
        );
    }
    run_ok(&file, &out, &["--overwrite"]);
    assert_same_dataset(&reference, &out, "made again with --overwrite");
    // An intact finished run is still complete, and says so.
    let o = run(&file, &out, &[]);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("already complete"));
}

/// A change made to a ledger line.
type LineEdit = fn(&str) -> String;

#[test]
fn a_checkpoint_changed_after_it_was_written_is_not_trusted() {
    // A checkpoint was trusted when its JSON parsed: a digit changed in the
    // ledger of a killed run (a flipped bit, an edit) made the resume skip
    // frames, cut the manifest inside a line, or number COCO ids wrong, and
    // end with status 0. Each checkpoint now carries its JSON's hash; a
    // changed one (and every one after it) is not trusted, and the resume
    // makes those frames again.
    let tmp = tempfile::tempdir().expect("tempdir");
    let p = preset();
    let file = common::preset_file(tmp.path(), &p, "p.ron");
    let reference = tmp.path().join("reference");
    run_ok(&file, &reference, &[]);
    let edits: [(&str, LineEdit); 2] = [
        ("next 10 -> 12", |l| {
            l.replace("\"next\":10,", "\"next\":12,")
        }),
        ("a manifest length one less", |l| {
            let (head, rest) = l
                .split_once("\"manifest.jsonl\":")
                .expect("manifest length");
            let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
            let less = digits.parse::<u64>().expect("length") - 1;
            format!("{head}\"manifest.jsonl\":{less}{}", &rest[digits.len()..])
        }),
    ];
    for (what, edit) in edits {
        let out = tmp.path().join(what.replace(' ', "_"));
        let child = batch_cmd(&file, &out, &[])
            .env("SWARMSHOT_STALL_AT", "checkpoint:10")
            .spawn()
            .expect("spawn");
        let manifest = out.join("manifest.jsonl");
        kill_when(child, "before checkpoint 10", || {
            std::fs::read_to_string(&manifest).is_ok_and(|m| m.lines().count() == 11)
        });
        let path = out.join(".swarmshot-ledger");
        let ledger = std::fs::read_to_string(&path).expect("ledger");
        let mut lines: Vec<String> = ledger.lines().map(str::to_owned).collect();
        let last = lines
            .iter()
            .rposition(|l| l.starts_with('='))
            .expect("checkpoint");
        let changed = edit(&lines[last]);
        assert_ne!(changed, lines[last], "{what}: the edit changed nothing");
        lines[last] = changed;
        std::fs::write(&path, lines.join("\n") + "\n").expect("edit the ledger");
        run_ok(&file, &out, &["--resume"]);
        assert_same_dataset(&reference, &out, what);
    }
}

#[test]
fn a_frame_killed_while_writing_keeps_the_earlier_files_whole() {
    // `swarmshot frame` wrote and renamed its files one at a time: killed
    // between two, the folder held some files of the new frame beside some
    // of the old, and a `.NAME.PID.tmp` nothing removed. Every file is now
    // written to its temporary name first, then all are renamed; the next
    // frame there removes a killed one's temporary files.
    let tmp = tempfile::tempdir().expect("tempdir");
    let mut p = preset();
    p.output.masks.instance_png = true;
    let file = common::preset_file(tmp.path(), &p, "p.ron");
    let frame = |dir: &Path, index: &str| {
        let mut cmd = Command::new(BIN);
        cmd.arg("frame")
            .arg(&file)
            .args(["--index", index, "--out", "f.jpg", "--overwrite"])
            .current_dir(dir)
            .env("RUST_BACKTRACE", "0")
            .stdout(Stdio::null())
            .stderr(Stdio::piped());
        cmd
    };
    let run_frame = |dir: &Path, index: &str| {
        let o = frame(dir, index).output().expect("frame");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    let names = ["f.jpg", "f.txt", "f.json", "f.mask.png"];
    let contents = |dir: &Path| names.map(|n| std::fs::read(dir.join(n)).expect("a frame file"));
    let (one, two) = (tmp.path().join("one"), tmp.path().join("two"));
    for (dir, index) in [(&one, "1"), (&two, "2")] {
        std::fs::create_dir(dir).expect("mkdir");
        run_frame(dir, index);
    }
    let (frame_one, frame_two) = (contents(&one), contents(&two));
    // A temporary file of a process that cannot exist (above Linux's pid_max).
    std::fs::write(one.join(".f.txt.4294967295.tmp"), "stale").expect("stale temp");
    let child = frame(&one, "2")
        .env("SWARMSHOT_STALL_AT", "frame:staged")
        .spawn()
        .expect("spawn");
    let pid = child.id();
    kill_when(child, "every file staged", || {
        names
            .iter()
            .all(|n| one.join(format!(".{n}.{pid}.tmp")).exists())
    });
    assert!(
        contents(&one) == frame_one,
        "a killed frame changed the earlier frame's files"
    );
    run_frame(&one, "2");
    assert!(contents(&one) == frame_two, "frame 2 made after the kill");
    let left: Vec<PathBuf> = common::files_under(&one)
        .into_iter()
        .filter(|p| p.to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
}

#[test]
fn a_finished_run_whose_checkpoint_changed_is_made_again_not_cut() {
    // A finished run's checkpoints are not checked against its files (its
    // COCO parts are gone). With a checkpoint changed, the done mark was not
    // trusted but the checkpoints before it were: the rerun cut the manifest
    // back, then failed on a missing COCO part ("is missing but the ledger
    // says it held N bytes"). Such a run is now no longer taken as finished,
    // its checkpoints are checked against its files, and the rerun makes it
    // again, byte for byte.
    let tmp = tempfile::tempdir().expect("tempdir");
    let (file, reference, out) = two_finished_runs(tmp.path());
    let path = out.join(".swarmshot-ledger");
    let ledger = std::fs::read_to_string(&path).expect("ledger");
    let mut lines: Vec<String> = ledger.lines().map(str::to_owned).collect();
    let last = lines
        .iter()
        .rposition(|l| l.starts_with('='))
        .expect("checkpoint");
    lines[last] = lines[last].replacen("={", "={\"x\":0,", 1);
    std::fs::write(&path, lines.join("\n") + "\n").expect("edit the ledger");
    run_ok(&file, &out, &[]);
    assert_same_dataset(&reference, &out, "a finished run whose checkpoint changed");
}

/// Frames in a dataset folder that also holds user files: images named by index.
fn assert_dataset_frames(dir: &Path) -> usize {
    let manifest = std::fs::read_to_string(dir.join("manifest.jsonl")).expect("manifest");
    for line in manifest.lines() {
        let v: serde_json::Value = serde_json::from_str(line).expect("json");
        let image = v["image"].as_str().expect("image");
        assert!(dir.join(image).is_file(), "{image}");
    }
    manifest.lines().count()
}
