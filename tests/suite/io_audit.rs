//! A hostile-input and data-safety audit of `merge`, `stats`, `frame`,
//! `gap` and `batch`'s paths (the twenty-first session, and the
//! thirty-eighth's: an empty manifest, a file of the user's at the lock's
//! name): each test fails without its fix. Every command runs as a child process, as a user runs it
//! (renders on lavapipe).

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use swarmshot::preset::Preset;

use common::cli::{BIN, batch, batch_args, err, ok, os, run};

/// `swarmshot` with no arguments yet, as [`common::cli::command`] makes it.
fn swarmshot() -> Command {
    common::cli::command::<&str>(&[])
}

/// `tiny_preset` (8 frames at 320×180) written as `dir/p.ron`.
fn preset_file(dir: &Path) -> PathBuf {
    let p: Preset = common::tiny_preset();
    common::preset_file(dir, &p, "p.ron")
}

/// The first 4 frames of `preset` as two shards, into `parts[0]` and `parts[1]`.
fn two_shards(preset: &Path, parts: &[PathBuf]) {
    for (k, part) in parts.iter().enumerate() {
        batch(
            preset,
            part,
            &["--limit", "4", "--shard", &format!("{k}/2")],
        );
    }
}

/// `frame PRESET --index 1 --out OUT`, which must fail; returns its standard error.
fn frame_refused(preset: &Path, out: &Path) -> String {
    err(&[
        os("frame"),
        preset.as_os_str(),
        os("--index"),
        os("1"),
        os("--out"),
        out.as_os_str(),
    ])
}

#[test]
fn a_shard_of_a_huge_shard_count_is_merged_into_a_named_refusal_not_memory() {
    // `--shard 0/100000000000` of a 2-frame run is a finished, empty shard;
    // merge listed every missing shard's name (10^11 strings) before it
    // said anything and aborted when memory ran out. It now names the
    // first missing shards and counts the rest. (The merge runs under a
    // 1 GiB address-space limit, so a regression fails fast.)
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let shard = tmp.path().join("s0");
    let said = batch(
        &file,
        &shard,
        &["--limit", "2", "--shard", "0/100000000000"],
    );
    // The warning counts the frames after --limit (it said "of the 8 there are").
    assert!(said.contains("no frame of the 2 there are"), "{said}");
    let out = tmp.path().join("merged");
    let start = Instant::now();
    let o = Command::new("bash")
        .arg("-c")
        .arg("ulimit -v 1048576; exec \"$0\" merge \"$1\" \"$2\"")
        .arg(BIN)
        .arg(&out)
        .arg(&shard)
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .output()
        .expect("run bash");
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "merged one shard of 10^11");
    assert!(
        e.contains("error: shards 1/100000000000, 2/100000000000")
            && e.contains("20/100000000000 and 99999999979 more are missing"),
        "{e}"
    );
    assert!(start.elapsed() < Duration::from_secs(20));
    assert!(!out.exists(), "a refused merge created its output folder");
}

#[test]
fn merge_never_writes_into_a_shard_inside_its_output_folder() {
    // A shard at OUT/labels (OUT holding the shards, `merge --overwrite OUT
    // OUT/labels OUT/s1`): merge wrote the merged dataset's labels/train/,
    // labels/val/ … into that shard's folder, which a later merge refused as
    // tampered. An output folder that holds a shard is now refused.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let out = tmp.path().join("out");
    let parts = [out.join("labels"), out.join("s1")];
    two_shards(&file, &parts);
    let before = common::files_under(&parts[0]);
    let e = err(&[
        os("merge"),
        os("--overwrite"),
        out.as_os_str(),
        parts[0].as_os_str(),
        parts[1].as_os_str(),
    ]);
    assert!(e.contains("is inside the output folder"), "{e}");
    assert_eq!(common::files_under(&parts[0]), before, "the shard changed");
    let names: Vec<_> = std::fs::read_dir(&out)
        .expect("read out")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(names.len(), 2, "merge wrote into OUT: {names:?}");
    // Shards beside the output folder merge as before.
    let beside = tmp.path().join("merged");
    ok(&[
        os("merge"),
        beside.as_os_str(),
        parts[0].as_os_str(),
        parts[1].as_os_str(),
    ]);
}

#[test]
fn a_frame_writes_into_the_folder_it_opened_even_when_it_is_swapped_for_a_link() {
    // `swarmshot frame` wrote its files by path: a folder moved away and
    // replaced by a link while the frame was made sent every file through the
    // link, replacing a user's file there that no check had seen (without
    // --overwrite). The folder is now opened before the frame is made and
    // every file is written relative to that handle.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let (dir, moved, elsewhere) = (
        tmp.path().join("frames"),
        tmp.path().join("frames.moved"),
        tmp.path().join("elsewhere"),
    );
    std::fs::create_dir(&dir).expect("mkdir");
    std::fs::create_dir(&elsewhere).expect("mkdir");
    std::fs::write(elsewhere.join("f.txt"), "precious").expect("write");
    let barrier = tmp.path().join("go");
    let child = swarmshot()
        .arg("frame")
        .arg(&file)
        .args(["--index", "1", "--out"])
        .arg(dir.join("f.png"))
        .env("SWARMSHOT_STALL_AT", "frame:writing")
        .env("SWARMSHOT_STALL_UNTIL", &barrier)
        .spawn()
        .expect("spawn");
    let stalled = tmp.path().join("go.stalled");
    let start = Instant::now();
    while !stalled.exists() {
        assert!(start.elapsed() < Duration::from_secs(120), "never stalled");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::fs::rename(&dir, &moved).expect("move the folder away");
    std::os::unix::fs::symlink(&elsewhere, &dir).expect("link in its place");
    std::fs::write(&barrier, "").expect("barrier");
    let o = child.wait_with_output().expect("frame");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(elsewhere.join("f.txt")).expect("read"),
        "precious",
        "the frame wrote through the link"
    );
    assert_eq!(common::files_under(&elsewhere), [PathBuf::from("f.txt")]);
    let written = common::files_under(&moved);
    assert_eq!(
        written,
        ["f.json", "f.png", "f.txt"].map(PathBuf::from),
        "the frame's files belong in the folder it opened"
    );
    // A folder that does not exist is named before anything is made.
    let e = frame_refused(&file, &tmp.path().join("nowhere/f.png"));
    assert!(
        e.contains("f.png: its folder") && e.contains("nowhere does not exist"),
        "{e}"
    );
}

#[test]
fn gap_refuses_a_dataset_compared_with_itself() {
    // `gap --real DIR --synthetic DIR` (or --real DIR/images/train) measured
    // the dataset's own frames as the footage and reported every statistic
    // inside the range. Sides that are one folder, or one inside the other,
    // are now refused by name before anything is measured.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let ds = tmp.path().join("ds");
    batch(&file, &ds, &["--limit", "2"]);
    let train = ds.join("images/train");
    for (real, synthetic, relation) in [
        (&ds, &ds, "the same folder as"),
        (&train, &ds, "inside"),
        (&ds, &train, "a folder holding"),
    ] {
        let e = err(&[
            os("gap"),
            os("--real"),
            real.as_os_str(),
            os("--synthetic"),
            synthetic.as_os_str(),
        ]);
        assert!(
            e.contains(&format!("is {relation} --synthetic")) && e.contains("own frames"),
            "{e}"
        );
    }
}

#[test]
fn stats_refuses_a_plots_path_that_is_a_file_before_printing() {
    // `stats DIR --plots FILE` printed the whole table, then failed naming
    // the path twice ("FILE: FILE: exists and is not a folder"). It is now
    // refused before the manifest is read.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let plan = tmp.path().join("plan");
    batch(&file, &plan, &["--labels-only"]);
    let o = run(&[
        os("stats"),
        plan.as_os_str(),
        os("--plots"),
        file.as_os_str(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(o.stdout.is_empty(), "printed before refusing");
    assert!(
        e.contains("--plots") && e.contains("exists and is not a folder"),
        "{e}"
    );
}

#[test]
fn a_batch_or_merge_into_another_datasets_frame_folders_is_refused() {
    // `batch --out DS/images/train/sub` wrote a whole dataset among DS's
    // training images: Ultralytics reads images/ recursively (and finds the
    // nested labels/ beside them), so DS trained on them. An output folder
    // inside another dataset's data folders is now refused before anything
    // is written; one beside them (DS/notes) is not.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let ds = tmp.path().join("ds");
    batch(&file, &ds, &["--labels-only"]);
    let before = common::files_under(&ds);
    for inside in ["labels/train/sub", "labels", "annotations/x"] {
        let out = ds.join(inside);
        let e = err(&[
            os("batch"),
            file.as_os_str(),
            os("--out"),
            out.as_os_str(),
            os("--labels-only"),
            os("--overwrite"),
        ]);
        let folder = inside.split('/').next().unwrap_or_default();
        assert!(
            e.contains(&format!(
                "is inside the {folder}/ folder of the swarmshot dataset"
            )),
            "{e}"
        );
        assert_eq!(common::files_under(&ds), before, "{inside}: DS changed");
    }
    // `frame` too: its files in DS/labels/train would be read as one of DS's frames.
    let out = ds.join("labels/train/f.png");
    let e = frame_refused(&file, &out);
    assert!(
        e.contains("is inside the labels/ folder of the swarmshot dataset"),
        "{e}"
    );
    assert_eq!(common::files_under(&ds), before, "frame: DS changed");
    batch(&file, &ds.join("notes"), &["--labels-only"]);
}

#[test]
fn a_shard_file_replaced_while_merge_runs_is_not_joined() {
    // merge checked every shard file against its content record, then read
    // the manifests and COCO files again by path: a manifest replaced (a new
    // file at its name) between the check and the read was joined unchecked,
    // with status 0. They are now read through the shard's folder handle,
    // and only the file that was checked.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let parts: Vec<PathBuf> = (0..2).map(|k| tmp.path().join(format!("s{k}"))).collect();
    two_shards(&file, &parts);
    let out = tmp.path().join("merged");
    let barrier = tmp.path().join("go");
    // Stopped after shard 0's records, before its checkpoint (frames 0..2).
    let child = swarmshot()
        .arg("merge")
        .arg(&out)
        .args(&parts)
        .env("SWARMSHOT_STALL_AT", "checkpoint:1")
        .env("SWARMSHOT_STALL_UNTIL", &barrier)
        .spawn()
        .expect("spawn");
    let stalled = tmp.path().join("go.stalled");
    let start = Instant::now();
    while !stalled.exists() {
        assert!(start.elapsed() < Duration::from_secs(60), "never stalled");
        std::thread::sleep(Duration::from_millis(20));
    }
    let manifest = parts[1].join("manifest.jsonl");
    let text = std::fs::read_to_string(&manifest).expect("manifest");
    let forged = tmp.path().join("forged.jsonl");
    std::fs::write(&forged, text.replace("\"split\":\"", "\"split\":\"x")).expect("write");
    std::fs::rename(&forged, &manifest).expect("replace the manifest");
    std::fs::write(&barrier, "").expect("barrier");
    let o = child.wait_with_output().expect("merge");
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "merged a manifest nobody checked");
    assert!(
        e.contains("manifest.jsonl") && e.contains("was replaced after its content was checked"),
        "{e}"
    );
    let merged = std::fs::read_to_string(out.join("manifest.jsonl")).unwrap_or_default();
    assert!(
        !merged.contains("\"split\":\"x"),
        "the forged lines were joined"
    );
}

#[test]
fn stats_never_writes_its_default_plots_through_a_link_in_the_dataset() {
    // `stats DIR` wrote its histograms into DIR/stats-plots, following a link
    // there (a dataset unpacked from someone else's archive) to wherever it
    // pointed. The default folder is now made and opened below DIR's handle
    // without following a link; a link is refused by name.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let plan = tmp.path().join("plan");
    batch(&file, &plan, &["--labels-only"]);
    let elsewhere = tmp.path().join("elsewhere");
    std::fs::create_dir(&elsewhere).expect("mkdir");
    std::os::unix::fs::symlink(&elsewhere, plan.join("stats-plots")).expect("symlink");
    let e = err(&[os("stats"), plan.as_os_str()]);
    assert!(
        e.contains("stats-plots") && e.contains("symbolic link"),
        "{e}"
    );
    assert!(
        common::files_under(&elsewhere).is_empty(),
        "wrote through the link"
    );
    // Without the link, the default folder is made as before.
    std::fs::remove_file(plan.join("stats-plots")).expect("unlink");
    ok(&[os("stats"), plan.as_os_str()]);
    assert!(plan.join("stats-plots/box_size.png").is_file());
}

#[test]
fn a_file_that_appears_while_a_frame_is_made_is_kept_without_overwrite() {
    // Without --overwrite, `frame` checked that its names were free before
    // making the frame, then renamed its files into place: a file written at
    // one of those names meanwhile (seconds for a large frame) was replaced.
    // Each file is now hard-linked to its name, which fails on a taken one.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let out = tmp.path().join("f.png");
    let barrier = tmp.path().join("go");
    let child = swarmshot()
        .arg("frame")
        .arg(&file)
        .args(["--index", "1", "--out"])
        .arg(&out)
        .env("SWARMSHOT_STALL_AT", "frame:writing")
        .env("SWARMSHOT_STALL_UNTIL", &barrier)
        .spawn()
        .expect("spawn");
    let stalled = tmp.path().join("go.stalled");
    let start = Instant::now();
    while !stalled.exists() {
        assert!(start.elapsed() < Duration::from_secs(120), "never stalled");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::fs::write(tmp.path().join("f.json"), "mine").expect("write");
    std::fs::write(&barrier, "").expect("barrier");
    let o = child.wait_with_output().expect("frame");
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success(),
        "the frame replaced a file without --overwrite"
    );
    assert!(
        e.contains("f.json") && e.contains("appeared while the frame was made"),
        "{e}"
    );
    assert_eq!(
        std::fs::read_to_string(tmp.path().join("f.json")).expect("read"),
        "mine"
    );
    assert!(!out.exists(), "the frame put some of its files in place");
    let temps: Vec<PathBuf> = common::files_under(tmp.path())
        .into_iter()
        .filter(|p| p.to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(temps.is_empty(), "temporary files left: {temps:?}");
}

#[test]
fn an_output_folder_that_is_a_link_to_nothing_is_named_as_such() {
    // `batch --out L` and `stats --plots L` with L a link to a path that does not
    // exist said only "L: No such file or directory" (of a name that is there);
    // the link is now named with where it points, and nothing is made there.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let gone = tmp.path().join("gone");
    let link = tmp.path().join("link");
    std::os::unix::fs::symlink(&gone, &link).expect("symlink");
    let named = format!("is a link to {}, which does not exist", gone.display());
    let e = err(&[os("batch"), file.as_os_str(), os("--out"), link.as_os_str()]);
    assert!(e.contains(&named), "{e}");
    let plan = tmp.path().join("plan");
    batch(&file, &plan, &["--labels-only"]);
    let e = err(&[
        os("stats"),
        plan.as_os_str(),
        os("--plots"),
        link.as_os_str(),
    ]);
    assert!(e.contains(&named), "{e}");
    assert!(!gone.exists(), "made the link's target");
}

#[test]
fn stats_of_a_run_stopped_before_its_first_frame_reports_no_frames() {
    // A batch killed before its first frame leaves an empty manifest.jsonl;
    // `stats` drew its histograms from no bins and panicked (exit 101). The
    // report and its plots are those of a dataset of no frames.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let plan = tmp.path().join("plan");
    batch(&file, &plan, &["--labels-only", "--limit", "2"]);
    for manifest in ["", "  \n\n"] {
        std::fs::write(plan.join("manifest.jsonl"), manifest).expect("manifest");
        let said = ok(&[os("stats"), plan.as_os_str()]);
        assert!(said.contains("| images | 0 |"), "{said}");
        assert!(plan.join("stats-plots/box_size.png").is_file());
    }
    // A manifest that is a folder is named as such, not as missing.
    std::fs::remove_file(plan.join("manifest.jsonl")).expect("rm");
    std::fs::create_dir(plan.join("manifest.jsonl")).expect("mkdir");
    let e = err(&[os("stats"), plan.as_os_str()]);
    assert!(e.contains("manifest.jsonl is not a regular file"), "{e}");
}

#[test]
fn a_shard_folder_that_is_not_there_is_named_as_missing() {
    // `merge OUT MISSING` said MISSING "holds no swarmshot run", and a
    // shard that is a file gave "Not a directory (os error 20)".
    let tmp = tempfile::tempdir().expect("tempdir");
    let out = tmp.path().join("out");
    let missing = tmp.path().join("s0");
    let e = err(&[os("merge"), out.as_os_str(), missing.as_os_str()]);
    assert!(e.contains("s0") && e.contains("does not exist"), "{e}");
    std::fs::write(&missing, "x").expect("write");
    let e = err(&[os("merge"), out.as_os_str(), missing.as_os_str()]);
    assert!(e.contains("s0") && e.contains("is not a folder"), "{e}");
}

#[test]
fn a_users_file_at_the_lock_name_is_refused_not_overwritten_and_deleted() {
    // The folder lock opened `.swarmshot-lock` for writing whatever stood
    // there: a user's file of that name was overwritten with the process
    // id and deleted when the run ended (even a run then refused). Only a
    // killed run's lock file (empty, or its process id) is taken over.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let out = tmp.path().join("out");
    std::fs::create_dir(&out).expect("mkdir");
    let lock = out.join(".swarmshot-lock");
    std::fs::write(&lock, "my notes\n").expect("write");
    let e = err(&batch_args(&file, &out, &["--labels-only", "--overwrite"]));
    assert!(
        e.contains(".swarmshot-lock") && e.contains("not swarmshot's lock file"),
        "{e}"
    );
    assert_eq!(std::fs::read(&lock).expect("kept"), b"my notes\n");
    // A folder there is named as such (it was "Is a directory (os error 21)").
    std::fs::remove_file(&lock).expect("rm");
    std::fs::create_dir(&lock).expect("mkdir");
    let e = err(&batch_args(&file, &out, &["--labels-only", "--overwrite"]));
    assert!(e.contains(".swarmshot-lock: is not a regular file"), "{e}");
    std::fs::remove_dir(&lock).expect("rmdir");
    // What a killed run leaves (its process id) is taken over, and gone at the end.
    std::fs::write(&lock, "4242\n").expect("write");
    batch(&file, &out, &["--labels-only", "--overwrite"]);
    assert!(!lock.exists());
}

#[test]
fn a_huge_shard_stats_file_is_refused_before_it_is_parsed() {
    // A shard's stats.json of 70 MB (its content record forged to match)
    // took 840 MB to parse into values. Over 16 MiB it is refused unread.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let parts = [tmp.path().join("s0"), tmp.path().join("s1")];
    two_shards(&file, &parts);
    // Valid JSON of 17 MiB, and the ledger's record of stats.json made to match.
    let big = format!("{{\"pad\": \"{}\"}}", "x".repeat(17 << 20));
    std::fs::write(parts[0].join("stats.json"), &big).expect("write");
    let ledger = parts[0].join(".swarmshot-ledger");
    let text = std::fs::read_to_string(&ledger).expect("ledger");
    let record = format!(
        "%{} blake3:{} stats.json",
        big.len(),
        blake3::hash(big.as_bytes()).to_hex()
    );
    let forged: Vec<String> = text
        .lines()
        .map(|l| {
            if l.starts_with('%') && l.ends_with(" stats.json") {
                record.clone()
            } else {
                l.to_owned()
            }
        })
        .collect();
    assert!(forged.contains(&record), "no record of stats.json:\n{text}");
    std::fs::write(&ledger, forged.join("\n") + "\n").expect("ledger");
    let out = tmp.path().join("out");
    let e = err(&[
        os("merge"),
        out.as_os_str(),
        parts[0].as_os_str(),
        parts[1].as_os_str(),
    ]);
    assert!(
        e.contains("stats.json") && e.contains("larger than any stats.json a run writes"),
        "{e}"
    );
}

#[test]
fn a_ledger_whose_checkpoint_lies_past_its_runs_end_is_refused() {
    // The header's frame count edited below the last checkpoint (frames=2
    // under a checkpoint at frame 8): `--resume` said "already complete"
    // and marked the folder done with the frames past that end in it.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = preset_file(tmp.path());
    let plan = tmp.path().join("plan");
    batch(&file, &plan, &["--labels-only"]);
    let ledger = plan.join(".swarmshot-ledger");
    let text = std::fs::read_to_string(&ledger).expect("ledger");
    let (header, rest) = text.split_once('\n').expect("a header");
    assert!(header.contains(" frames=8 "), "{header}");
    let edited = header.replace(" frames=8 ", " frames=2 ");
    std::fs::write(&ledger, format!("{edited}\n{rest}")).expect("ledger");
    let before = common::files_under(&plan);
    let e = err(&batch_args(&file, &plan, &["--labels-only", "--resume"]));
    assert!(
        e.contains(".swarmshot-ledger") && e.contains("past the end of its run (2 frames)"),
        "{e}"
    );
    assert_eq!(common::files_under(&plan), before, "changed the folder");
}

/// A model cache pointed at the output folder (or an output folder inside
/// the cache) is refused before anything is written, naming the variable:
/// loading the models would have put the cache's files in the folder, and
/// every run after would have found it not empty.
#[test]
fn a_batch_whose_output_folder_holds_the_model_cache_is_refused_before_writing() {
    let dir = tempfile::tempdir().expect("temp dir");
    let preset = preset_file(dir.path());
    let cache = dir.path().join("cache");
    for out in [cache.clone(), cache.join("lod").join("set")] {
        let o = swarmshot()
            .args(batch_args(&preset, &out, &[]))
            .env("SWARMSHOT_CACHE_DIR", &cache)
            .output()
            .expect("run swarmshot");
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{}: {e}", out.display());
        assert!(
            e.contains("SWARMSHOT_CACHE_DIR") && e.contains("model cache"),
            "{e}"
        );
        assert!(
            !cache.exists(),
            "{}: the cache folder was written",
            out.display()
        );
    }
    // The same folders with the cache elsewhere are fine.
    let o = swarmshot()
        .args(batch_args(&preset, &cache, &["--limit", "1"]))
        .env("SWARMSHOT_CACHE_DIR", dir.path().join("elsewhere"))
        .output()
        .expect("run swarmshot");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}
