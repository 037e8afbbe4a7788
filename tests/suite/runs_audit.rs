//! Sequences of runs in one folder with different flags (`batch` with
//! `--resume`, `--shard`, `--labels-only`, `--limit`, `--every`, and `merge`):
//! a refusal changes nothing on disk and names the command that continues
//! the earlier run, not only `--overwrite`, which deletes it; a run is
//! continued, run again or merged only from the input files it began with.

use crate::common;

use std::path::Path;

use common::cli::{batch, batch_args, err, jpeg_preset, ok, os};
use swarmshot::preset::ModelSource;
use swarmshot::preset::backplate::Backplate;

/// Every entry under `dir` with its size and modification time (the lock
/// file, which a refused run may take and give back, aside).
fn listing(dir: &Path) -> Vec<(String, u64, std::time::SystemTime)> {
    let mut all: Vec<_> = common::files_under(dir)
        .into_iter()
        .filter(|rel| rel.file_name().is_some_and(|n| n != ".swarmshot-lock"))
        .map(|rel| {
            let m = std::fs::symlink_metadata(dir.join(&rel)).expect("stat");
            (
                rel.display().to_string(),
                m.len(),
                m.modified().expect("mtime"),
            )
        })
        .collect();
    all.sort();
    all
}

/// `swarmshot batch PRESET --out OUT EXTRA…`, which must fail: its stderr,
/// after checking that nothing under OUT changed.
fn refused(preset: &Path, out: &Path, extra: &[&str]) -> String {
    let before = listing(out);
    let e = err(&batch_args(preset, out, extra));
    assert_eq!(listing(out), before, "the refusal changed the folder: {e}");
    e
}

#[test]
fn a_run_refused_for_a_missing_flag_names_the_flags_that_continue_it() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let preset = common::preset_file(tmp.path(), &jpeg_preset(1), "p.ron");
    let (shard, plan, whole) = (
        tmp.path().join("shard1"),
        tmp.path().join("plan"),
        tmp.path().join("whole"),
    );
    batch(&preset, &shard, &["--shard", "1/2", "--limit", "3"]);
    batch(&preset, &plan, &["--labels-only"]);
    batch(&preset, &whole, &["--limit", "2"]);

    // --shard left out: the shard is continued by naming it, not deleted.
    let e = refused(&preset, &shard, &["--resume"]);
    assert!(
        e.contains(
            "to continue it, run the batch with --resume --shard 1/2 (no --limit, no --every)"
        ),
        "{e}"
    );
    batch(&preset, &shard, &["--resume", "--shard", "1/2"]);

    // A plan continued as a rendered run, and a rendered run as a plan.
    let e = refused(&preset, &plan, &["--resume"]);
    assert!(
        e.contains("with --resume --labels-only (no --limit)"),
        "{e}"
    );
    let e = refused(&preset, &whole, &["--labels-only", "--resume"]);
    assert!(
        e.contains("with --resume (no --labels-only, no --limit, no --every)"),
        "{e}"
    );
    // --shard into a whole run; --limit changed on --resume.
    let e = refused(&preset, &whole, &["--resume", "--shard", "0/2"]);
    assert!(
        e.contains("with --resume (no --shard, no --limit, no --every)"),
        "{e}"
    );
    let e = refused(&preset, &whole, &["--resume", "--limit", "3"]);
    assert!(e.contains("with --resume (no --limit, no --every)"), "{e}");
    batch(&preset, &whole, &["--resume"]);

    // Another preset is not continued by any flag; a merge names no batch flag.
    let mut other = jpeg_preset(1);
    other.seed += 1;
    let other = common::preset_file(tmp.path(), &other, "other.ron");
    let e = refused(&other, &whole, &["--resume"]);
    assert!(!e.contains("to continue it"), "{e}");
    let shard0 = tmp.path().join("shard0");
    batch(&preset, &shard0, &["--shard", "0/2", "--limit", "3"]);
    let before = listing(&whole);
    let e = err(&[
        os("merge"),
        whole.as_os_str(),
        shard0.as_os_str(),
        shard.as_os_str(),
    ]);
    assert!(!e.contains("to continue it"), "{e}");
    assert_eq!(listing(&whole), before);
    ok(&[
        os("merge"),
        tmp.path().join("merged").as_os_str(),
        shard0.as_os_str(),
        shard.as_os_str(),
    ]);
}

/// `merge` again into a folder that already holds the whole run (a finished
/// merge, or a finished batch of the same preset) joins nothing and says so:
/// it used to report the shards "joined by an earlier, interrupted merge".
#[test]
fn merge_into_a_folder_that_holds_the_whole_run_says_already_complete() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let preset = common::preset_file(tmp.path(), &jpeg_preset(1), "p.ron");
    let shards: Vec<_> = (0..2)
        .map(|k| {
            let dir = tmp.path().join(format!("shard{k}"));
            batch(&preset, &dir, &["--shard", &format!("{k}/2")]);
            dir
        })
        .collect();
    let (merged, whole) = (tmp.path().join("merged"), tmp.path().join("whole"));
    batch(&preset, &whole, &[]);
    let merge = |out: &Path| {
        let mut args = vec![os("merge"), out.as_os_str()];
        args.extend(shards.iter().map(|s| s.as_os_str()));
        ok(&args)
    };
    assert!(merge(&merged).contains("merged 2 shards into"));
    for out in [&merged, &whole] {
        let before = listing(out);
        let said = merge(out);
        assert!(
            said.contains("already complete:") && said.contains("nothing merged"),
            "{said}"
        );
        assert!(!said.contains("interrupted"), "{said}");
        assert_eq!(listing(out), before, "{said}");
    }
    common::assert_same_dataset(&whole, &merged, "merge and batch");
}

/// A preset drawing `dir/BoxTextured.gltf`, a copy of the Khronos sample
/// whose buffer and texture are files beside it.
fn preset_with_model_files(dir: &Path) -> std::path::PathBuf {
    let model = dir.join("model");
    std::fs::create_dir(&model).expect("mkdir");
    let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/gltf/BoxTextured/glTF");
    for f in ["BoxTextured.gltf", "BoxTextured0.bin", "CesiumLogoFlat.png"] {
        std::fs::copy(sample.join(f), model.join(f)).expect("copy the model");
    }
    let mut p = jpeg_preset(1);
    p.models[0].source = ModelSource::File(model.join("BoxTextured.gltf"));
    common::preset_file(dir, &p, "model.ron")
}

/// Replace the PNG `texture` by another (a bundled real frame).
fn swap_for_another_png(texture: &Path) {
    let other =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real/images/V_DRONE_001_f150.png");
    std::fs::copy(other, texture).expect("swap the texture");
}

/// A run killed at its second frame's checkpoint.
fn killed_at_frame_1(preset: &Path, out: &Path, barrier: &Path) {
    killed_at(preset, out, barrier, "checkpoint:1", &[]);
}

/// A run (`batch … EXTRA`) killed at the test hook's `point`; `barrier` is new.
fn killed_at(preset: &Path, out: &Path, barrier: &Path, point: &str, extra: &[&str]) {
    let mut child = common::cli::command(&batch_args(preset, out, extra))
        .env("SWARMSHOT_STALL_AT", point)
        .env("SWARMSHOT_STALL_UNTIL", barrier)
        .spawn()
        .expect("spawn");
    let stalled = barrier.with_extension("stalled");
    let start = std::time::Instant::now();
    while !stalled.exists() {
        assert!(start.elapsed().as_secs() < 120, "never stalled");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().expect("kill -9");
    child.wait().expect("reaped");
}

/// A model file, one its URIs name, or a backplate replaced between a kill
/// and `--resume` (or before a run again or a merge) made a dataset of both:
/// the run identity was the locked preset, which holds only paths. The
/// ledger records what the inputs held, and a run from other content is
/// refused, changing nothing, naming the input.
#[test]
fn a_run_is_continued_only_from_the_input_files_it_began_with() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let preset = preset_with_model_files(tmp.path());
    let texture = tmp.path().join("model/CesiumLogoFlat.png");
    let original = std::fs::read(&texture).expect("texture");
    let swap_texture = || swap_for_another_png(&texture);
    let restore = || std::fs::write(&texture, &original).expect("restore the texture");

    // Killed, the texture swapped, then --resume: refused.
    let out = tmp.path().join("out");
    killed_at_frame_1(&preset, &out, &tmp.path().join("go"));
    swap_texture();
    let e = refused(&preset, &out, &["--resume"]);
    assert!(
        e.contains("made from other input files")
            && e.contains("models ")
            && e.contains("BoxTextured.gltf")
            && e.contains("continuing it would mix frames of both"),
        "{e}"
    );
    // The files as they were: it finishes as one run does.
    restore();
    batch(&preset, &out, &["--resume"]);
    let whole = tmp.path().join("whole");
    batch(&preset, &whole, &[]);
    common::assert_same_dataset(&whole, &out, "resumed and whole");

    // A finished run, run again from another buffer: refused; --overwrite remakes it.
    let buffer = tmp.path().join("model/BoxTextured0.bin");
    let mut bytes = std::fs::read(&buffer).expect("buffer");
    bytes.push(0);
    std::fs::write(&buffer, bytes).expect("change the buffer");
    let e = refused(&preset, &whole, &[]);
    assert!(
        e.contains("BoxTextured.gltf") && e.contains("--overwrite"),
        "{e}"
    );
    batch(&preset, &whole, &["--overwrite"]);
    batch(&preset, &whole, &[]);

    // Shards made from different files are not merged.
    let shard = |k: u32| {
        let dir = tmp.path().join(format!("shard{k}"));
        batch(&preset, &dir, &["--shard", &format!("{k}/2")]);
        dir
    };
    let first = shard(0);
    swap_texture();
    let second = shard(1);
    let merge = |out: &Path, first: &Path| {
        err(&[
            os("merge"),
            out.as_os_str(),
            first.as_os_str(),
            second.as_os_str(),
        ])
    };
    let merged = tmp.path().join("merged");
    let e = merge(&merged, &first);
    assert!(
        e.contains("made from other input files") && e.contains("BoxTextured.gltf"),
        "{e}"
    );
    assert!(!merged.join("manifest.jsonl").exists(), "{e}");
    // Shards of one content merged into a run made from another: refused.
    std::fs::remove_dir_all(&first).expect("rm");
    let first = shard(0);
    let before = listing(&whole);
    let e = merge(&whole, &first);
    assert!(
        e.contains("made from other input files than the shards") && e.contains("--overwrite"),
        "{e}"
    );
    assert_eq!(listing(&whole), before, "{e}");
}

/// A backplate added to the folder between a kill and `--resume` changes
/// the plates a frame draws from: refused like a changed model.
#[test]
fn a_backplate_folder_changed_under_a_run_is_refused() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let plates = tmp.path().join("plates");
    std::fs::create_dir(&plates).expect("mkdir");
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/plates");
    for f in ["V_DRONE_010.jpg", "V_DRONE_010.plate.ron"] {
        std::fs::copy(data.join(f), plates.join(f)).expect("copy a plate");
    }
    let mut p = jpeg_preset(1);
    p.backplate = Some(Backplate {
        folder: plates.clone(),
        ..Default::default()
    });
    let preset = common::preset_file(tmp.path(), &p, "plates.ron");
    let out = tmp.path().join("out");
    killed_at_frame_1(&preset, &out, &tmp.path().join("go"));
    std::fs::copy(data.join("V_DRONE_050.jpg"), plates.join("V_DRONE_050.jpg")).expect("add");
    let e = refused(&preset, &out, &["--resume"]);
    assert!(
        e.contains("backplate.folder") && e.contains("made from other input files"),
        "{e}"
    );
    std::fs::remove_file(plates.join("V_DRONE_050.jpg")).expect("remove");
    batch(&preset, &out, &["--resume"]);
}

/// A ledger that records no inputs (written by a swarmshot before the
/// record) is continued as before, and records them from then on.
#[test]
fn a_run_whose_ledger_records_no_inputs_records_them_when_continued() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let preset = preset_with_model_files(tmp.path());
    let out = tmp.path().join("out");
    killed_at_frame_1(&preset, &out, &tmp.path().join("go1"));
    let ledger = out.join(".swarmshot-ledger");
    let text = std::fs::read_to_string(&ledger).expect("ledger");
    let old: String = (text.split_inclusive('\n'))
        .filter(|line| !line.starts_with('^'))
        .collect();
    assert!(old.len() < text.len(), "no records in {text}");
    std::fs::write(&ledger, old).expect("an older ledger");
    killed_at(
        &preset,
        &out,
        &tmp.path().join("go2"),
        "checkpoint:2",
        &["--resume"],
    );
    let text = std::fs::read_to_string(&ledger).expect("ledger");
    let second = text.lines().nth(1).unwrap_or_default();
    assert!(second.starts_with("^models blake3:"), "{text}");
    let texture = tmp.path().join("model/CesiumLogoFlat.png");
    let original = std::fs::read(&texture).expect("texture");
    swap_for_another_png(&texture);
    let e = refused(&preset, &out, &["--resume"]);
    assert!(e.contains("made from other input files"), "{e}");
    std::fs::write(&texture, original).expect("restore");
    batch(&preset, &out, &["--resume"]);
    let whole = tmp.path().join("whole");
    batch(&preset, &whole, &[]);
    common::assert_same_dataset(&whole, &out, "resumed and whole");
}
