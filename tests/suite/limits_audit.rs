//! The resource limits a cluster job or a locked-down machine runs under
//! (the limits audit): address space (`ulimit -v`) and open files
//! (`ulimit -n`). Each limit applies to the child alone, set by `bash -c
//! 'ulimit …; exec swarmshot …'`; each test fails without its fix.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use swarmshot::preset::{ModelSource, ModelSpec, Preset, Resolution};

use common::cli::{BIN, batch_args};

/// `swarmshot ARGS…` under the shell limits `limits` (such as `ulimit -v 2097152`),
/// no core dump written if it aborts.
fn under_limits(limits: &str, args: &[&std::ffi::OsStr]) -> Output {
    Command::new("bash")
        .arg("-c")
        .arg(format!("ulimit -c 0; {limits}; exec \"$0\" \"$@\""))
        .arg(BIN)
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .stdin(Stdio::null())
        .output()
        .expect("run bash")
}

/// `batch PRESET --out OUT --limit 2` under `limits`.
fn batch_under(limits: &str, preset: &Path, out: &Path) -> Output {
    under_limits(limits, &batch_args(preset, out, &["--limit", "2"]))
}

/// `tiny_preset` at `width`×`height` with MSAA `msaa`, written as `dir/p.ron`.
fn preset_file(dir: &Path, width: u32, height: u32, msaa: u32) -> PathBuf {
    let mut p: Preset = common::tiny_preset();
    p.render.resolution = Resolution::Custom { width, height };
    p.render.msaa = msaa;
    common::preset_file(dir, &p, "p.ron")
}

/// Asserts a refusal: exit code 1 (not an abort's signal), an `error:`
/// holding every piece of `says`, and no output folder.
fn assert_refused(o: &Output, says: &[&str], out: &Path) {
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        o.status.code(),
        Some(1),
        "not a refusal: {:?}\n{e}",
        o.status
    );
    let error = &e[e.find("error: ").unwrap_or_else(|| panic!("no error: {e}"))..];
    for s in says {
        assert!(error.contains(s), "{s:?} not in {error}");
    }
    assert!(!out.exists(), "a refused run created its output folder");
}

#[test]
fn a_frame_past_the_address_space_limit_is_refused_before_anything_is_written() {
    // A 5120×2880 MSAA 4 frame (about 1.5 GiB by the estimate) under a
    // 2 GiB address-space limit: the memory check read only MemAvailable,
    // so the batch made its folder and ledger, then aborted mid-frame with
    // "memory allocation of 58982400 bytes failed" (SIGABRT, a core dump).
    // The check now counts the address space left under `ulimit -v`.
    let tmp = tempfile::tempdir().expect("tempdir");
    let preset = preset_file(tmp.path(), 5120, 2880, 4);
    let out = tmp.path().join("out");
    let o = batch_under("ulimit -v 2097152", &preset, &out);
    assert_refused(&o, &["memory per frame", "ulimit -v"], &out);
}

#[test]
fn a_gpu_that_cannot_start_under_an_address_space_limit_names_the_limit() {
    // Under 256 MiB lavapipe cannot load, and the error said "no GPU adapter
    // found: install Mesa's software Vulkan driver", a driver that was there.
    let tmp = tempfile::tempdir().expect("tempdir");
    let preset = preset_file(tmp.path(), 320, 180, 1);
    let out = tmp.path().join("out");
    let o = batch_under("ulimit -v 262144", &preset, &out);
    assert_refused(&o, &["address-space limit of 256 MiB", "ulimit -v"], &out);
}

#[test]
fn a_low_soft_open_file_limit_is_raised_to_the_hard_one() {
    // `ulimit -Sn 24` (the hard limit left high): the batch failed with
    // "Too many open files" after its folder was made; it now raises its
    // soft limit, as any process may, and runs.
    let tmp = tempfile::tempdir().expect("tempdir");
    let preset = preset_file(tmp.path(), 320, 180, 1);
    let out = tmp.path().join("out");
    let o = batch_under("ulimit -Sn 24", &preset, &out);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{e}");
    assert!(out.join("stats.json").is_file());
}

#[test]
fn an_open_file_limit_too_low_to_run_is_refused_before_anything_is_written() {
    // `ulimit -n 24` (soft and hard): the batch made its folder and ledger,
    // then failed writing frame 0 with EMFILE. It is now refused first,
    // naming the limit and what to raise it to.
    let tmp = tempfile::tempdir().expect("tempdir");
    let preset = preset_file(tmp.path(), 320, 180, 1);
    let out = tmp.path().join("out");
    let o = batch_under("ulimit -n 24", &preset, &out);
    assert_refused(&o, &["open-file limit is 24", "ulimit -n 64"], &out);
}

#[test]
fn a_merge_under_a_low_open_file_limit_is_refused_before_anything_is_written() {
    // `merge` of two good shards under `ulimit -n 8` said the shards' files
    // "differ from what its ledger recorded … run that shard again", every
    // file having failed to open with EMFILE; under 24 it failed after
    // making its output folder. It is now refused first, naming the limit.
    let tmp = tempfile::tempdir().expect("tempdir");
    let preset = preset_file(tmp.path(), 320, 180, 1);
    let shards: Vec<PathBuf> = (0..2).map(|k| tmp.path().join(format!("s{k}"))).collect();
    for (k, shard) in shards.iter().enumerate() {
        common::cli::batch(
            &preset,
            shard,
            &["--limit", "4", "--shard", &format!("{k}/2")],
        );
    }
    let out = tmp.path().join("merged");
    for limit in ["ulimit -n 8", "ulimit -n 24"] {
        let args = [
            "merge".as_ref(),
            out.as_os_str(),
            shards[0].as_os_str(),
            shards[1].as_os_str(),
        ];
        let o = under_limits(limit, &args);
        assert_refused(
            &o,
            &["open-file limit is", "a merge needs", "ulimit -n 64"],
            &out,
        );
    }
}

#[test]
fn sighup_sigusr1_and_sigxcpu_stop_a_batch_cleanly_and_resume_byte_identical() {
    // SIGHUP (the terminal or SSH session closed), SIGUSR1 (Slurm's
    // `--signal=USR1@T` before the time limit) and SIGXCPU (`ulimit -t`'s
    // soft limit) killed the batch mid-frame by their default action, with
    // no line saying what stopped it. They now stop it as SIGTERM does.
    for (signal, says) in [
        ("HUP", "stopped by SIGHUP after"),
        ("USR1", "stopped by SIGUSR1 after"),
        (
            "XCPU",
            "stopped by SIGXCPU (the CPU-time limit, `ulimit -t`) after",
        ),
    ] {
        crate::output_trust::stops_cleanly_and_resumes(signal, says);
    }
}

/// A one-triangle .gltf whose mesh hangs at the end of a chain of `depth`
/// nodes, each the only child of the one before.
fn node_chain_gltf(depth: usize) -> String {
    let mut nodes: Vec<String> = (1..depth)
        .map(|i| format!("{{\"children\":[{i}]}}"))
        .collect();
    nodes.push("{\"mesh\":0}".into());
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
"buffers":[{{"byteLength":44,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA="}}]}}"#,
        nodes.join(",")
    )
}

#[test]
fn a_deep_gltf_node_chain_loads_on_a_small_stack() {
    // 250 nested nodes (the reader allows 256) were walked by recursion, and
    // under `ulimit -s 256` `check` died: "thread 'main' has overflowed its
    // stack", SIGABRT. The walk now keeps its own stack.
    let tmp = tempfile::tempdir().expect("tempdir");
    std::fs::write(tmp.path().join("chain.gltf"), node_chain_gltf(250)).expect("write gltf");
    let mut p: Preset = common::tiny_preset();
    p.models = vec![ModelSpec {
        source: ModelSource::File("chain.gltf".into()),
        size_m: 0.35,
        class: "uav".into(),
        ..ModelSpec::default()
    }];
    let preset = common::preset_file(tmp.path(), &p, "p.ron");
    let o = under_limits("ulimit -s 256", &["check".as_ref(), preset.as_os_str()]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{:?}\n{e}", o.status);
}

/// `ulimit -u` binds only an unprivileged user, so as root the child runs
/// as `nobody` (setpriv, util-linux); `None` where that cannot be done.
fn as_nobody() -> Option<&'static str> {
    let root = rustix::process::geteuid().is_root();
    let setpriv = Command::new("setpriv").arg("--version").output();
    (root && setpriv.is_ok_and(|o| o.status.success()))
        .then_some("setpriv --reuid=65534 --regid=65534 --clear-groups")
}

#[test]
fn a_thread_limit_is_a_named_error_and_the_dataset_resumes() {
    // Under `ulimit -u 8` the batch panicked ("failed to spawn thread: …
    // Resource temporarily unavailable", `Scope::spawn`); under 1 to 3 the
    // GPU's and the sky's helper threads did. Helper threads now fall back
    // to the calling thread, and the batch's own threads are a named error
    // whose dataset `--resume` completes byte-identically.
    let Some(nobody) = as_nobody() else {
        eprintln!("skipped: needs root and setpriv to run a child under ulimit -u");
        return;
    };
    let tmp = tempfile::tempdir().expect("tempdir");
    // `nobody` writes the output folders here.
    std::fs::set_permissions(
        tmp.path(),
        std::os::unix::fs::PermissionsExt::from_mode(0o777),
    )
    .expect("chmod");
    let preset = preset_file(tmp.path(), 320, 180, 1);
    let reference = tmp.path().join("ref");
    common::cli::batch(&preset, &reference, &["--limit", "2"]);
    for limit in [1, 8] {
        let out = tmp.path().join(format!("u{limit}"));
        let o = Command::new("bash")
            .arg("-c")
            .arg(format!(
                "exec {nobody} bash -c 'ulimit -c 0; ulimit -u {limit}; exec \"$0\" \"$@\"' \"$0\" \"$@\""
            ))
            .arg(BIN)
            .args(["batch".as_ref(), preset.as_os_str(), "--out".as_ref(), out.as_os_str()])
            .args(["--limit", "2"])
            .env("RUST_BACKTRACE", "0")
            .stdin(Stdio::null())
            .output()
            .expect("run bash");
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(
            o.status.code(),
            Some(1),
            "ulimit -u {limit}: {:?}\n{e}",
            o.status
        );
        assert!(e.contains("error: ") && !e.contains("panicked"), "{e}");
        if out.exists() {
            common::cli::batch(&preset, &out, &["--limit", "2", "--resume"]);
            common::assert_same_dataset(&reference, &out, "resumed after the thread limit");
        }
    }
}
