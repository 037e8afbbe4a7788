//! Sequences of runs in one folder with different flags (`batch` with
//! `--resume`, `--shard`, `--labels-only`, `--limit`, `--every`, and `merge`):
//! a refusal changes nothing on disk and names the command that continues
//! the earlier run, not only `--overwrite`, which deletes it.

use crate::common;

use std::path::Path;

use common::cli::{batch, batch_args, err, jpeg_preset, ok, os};

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
