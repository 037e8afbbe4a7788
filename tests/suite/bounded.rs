//! Bounded work (issue 35; docs/reliability.md section 7): a
//! labels-only plan's memory follows the size of its frames, not their
//! number; a plan the disk or the memory cannot hold is refused before
//! anything is written. The CLI cases run `swarmshot` as a child, as a user
//! would, and read its peak memory from /proc.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use swarmshot::pipeline::plan::{
    CHUNK, CHUNK_OBJECTS, IN_FLIGHT_OBJECTS, PlanRefused, PlanShape, check_plan_fits,
};
use swarmshot::preset::{LabelFormat, Placement, Preset, Volume};

fn swarmshot() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_swarmshot"));
    c.stdin(Stdio::null());
    c
}

fn write_preset(dir: &Path, name: &str, p: &Preset) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, p.to_ron()).expect("write preset");
    path
}

/// `count` drones a frame, spread through a 10 km box, YOLO and COCO, 8 frames.
fn crowded(count: u32) -> Preset {
    let mut p = common::tiny_preset();
    p.placement = Placement::Randomized {
        count: (count, count),
        count_distribution: Default::default(),
        volume: Volume::Box {
            size_m: (10_000.0, 10_000.0, 10_000.0),
        },
        min_separation_m: 0.7,
    };
    p.output.label_formats = vec![LabelFormat::Yolo, LabelFormat::Coco];
    assert_eq!(p.frame_count(), 8);
    p
}

/// Run `cmd` to its end (at most `limit`), reading its peak resident memory
/// (`VmHWM` in /proc/PID/status) as it runs: its output and the peak in bytes.
fn run_measured(mut cmd: Command, limit: Duration) -> (std::process::Output, u64) {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn swarmshot");
    let status = PathBuf::from(format!("/proc/{}/status", child.id()));
    let start = Instant::now();
    let mut peak_kib = 0u64;
    loop {
        // The last reading before the process is reaped holds its whole peak.
        if let Ok(text) = std::fs::read_to_string(&status)
            && let Some(kib) = text
                .lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        {
            peak_kib = peak_kib.max(kib);
        }
        if child.try_wait().expect("wait").is_some() {
            break;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().expect("output");
            panic!(
                "still running after {limit:?}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    (child.wait_with_output().expect("output"), peak_kib * 1024)
}

/// 150 000 drones a frame, three frames: the plan held every frame of a
/// chunk (up to 256) at once and grew with the frames (3.8 GB for three
/// frames of 10⁶, 1.9 GB now); it now holds one such frame at a time, and
/// its peak stays under the estimate that refuses plans too large for the
/// memory (about 1.5 times the old peak of three frames under it).
#[test]
fn a_labels_only_plan_of_large_frames_holds_one_frame_at_a_time() {
    const DRONES: u32 = 150_000;
    let p = crowded(DRONES);
    let shape = PlanShape::of(&p, 2);
    assert_eq!(
        (shape.frames_per_chunk, shape.chunks_in_flight),
        (1, 1),
        "{shape:?}"
    );
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write_preset(dir.path(), "crowded.ron", &p);
    let out_dir = dir.path().join("plan");
    let (out, peak) = run_measured(
        {
            let mut c = swarmshot();
            c.arg("batch")
                .arg(&path)
                .args(["--labels-only", "--limit", "3", "--threads", "2", "--out"])
                .arg(&out_dir);
            c
        },
        Duration::from_secs(120),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let manifest = std::fs::read_to_string(out_dir.join("manifest.jsonl")).expect("manifest");
    assert_eq!(manifest.lines().count(), 3);
    // One frame's objects as the estimate counts them, and the process besides.
    let one_frame = p.plan_memory_bytes(u64::from(DRONES));
    eprintln!(
        "peak {:.0} MiB, one frame's estimate {:.0} MiB",
        peak as f64 / 1048576.0,
        one_frame / 1048576.0
    );
    assert!(
        (peak as f64) < one_frame,
        "peak resident memory {peak} B is more than one frame's estimate {one_frame:.0} B"
    );
}

#[test]
fn plan_chunks_follow_the_frames_size() {
    let small = common::tiny_preset(); // 3–6 drones a frame
    let shape = PlanShape::of(&small, 4);
    assert_eq!(shape.frames_per_chunk, CHUNK);
    assert_eq!(shape.chunks_in_flight, 3 * 4 + 1);
    let mid = crowded(10_000);
    let shape = PlanShape::of(&mid, 4);
    assert_eq!(shape.frames_per_chunk, CHUNK_OBJECTS / 10_000);
    assert!(shape.objects_in_flight() <= IN_FLIGHT_OBJECTS, "{shape:?}");
    // A frame past the chunk's budget is a chunk alone, and alone in flight.
    let huge = crowded(1_000_000);
    let shape = PlanShape::of(&huge, 16);
    assert_eq!((shape.frames_per_chunk, shape.chunks_in_flight), (1, 1));
    assert_eq!(shape.objects_in_flight(), 1_000_000);
    // Confusers are objects too.
    let mut birds = crowded(60_000);
    birds.confusers = vec![swarmshot::preset::confusers::Confuser {
        count: (500, 500),
        ..Default::default()
    }];
    assert_eq!(PlanShape::of(&birds, 1).objects_per_frame, 60_500);
}

#[test]
fn a_plan_the_memory_cannot_hold_is_refused_by_name() {
    let huge = crowded(1_000_000);
    let shape = PlanShape::of(&huge, 2);
    let out = Path::new("/nonexistent/plan");
    let refused = check_plan_fits(&huge, &shape, (out, 8), (None, Some(512 << 20)))
        .expect_err("10⁶ objects in 512 MiB");
    assert!(matches!(
        refused,
        PlanRefused::NoMemory {
            objects: 1_000_000,
            ..
        }
    ));
    let msg = refused.to_string();
    assert!(
        msg.starts_with("placement: ") && msg.contains("1000000 per frame"),
        "{msg}"
    );
    check_plan_fits(&huge, &shape, (out, 8), (None, Some(64 << 30))).expect("fits 64 GiB");
    check_plan_fits(&huge, &shape, (out, 8), (None, None)).expect("memory not known");
}

/// The rendered batch refused a run the free space could not hold; a
/// labels-only plan did not look. It now does, before writing anything.
#[test]
fn a_labels_only_plan_larger_than_the_free_space_is_refused_before_writing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut p = crowded(1_000);
    p.repeats = 10_000_000; // 4·10⁷ frames of 1 000 drones: about 40 TiB of labels
    let path = write_preset(dir.path(), "huge.ron", &p);
    let out_dir = dir.path().join("plan");
    let out = swarmshot()
        .arg("batch")
        .arg(&path)
        .args(["--labels-only", "--out"])
        .arg(&out_dir)
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("40000000 frames need about")
            && err.contains("labels only, no images")
            && err.contains("free"),
        "{err}"
    );
    assert!(!out_dir.exists(), "nothing written");
    // The estimate itself: labels and ledger, no images.
    let e = p.plan_disk_estimate(10, 1_000.0);
    assert_eq!(e.image_bytes, 0.0);
    assert!(e.label_bytes > 10.0 * 1_000.0 * 1_000.0, "{e:?}");
    let check = check_plan_fits(
        &p,
        &PlanShape::of(&p, 1),
        (&out_dir, 10),
        (Some(1 << 20), None),
    );
    assert!(
        matches!(check, Err(PlanRefused::NoSpace { frames: 10, .. })),
        "{check:?}"
    );
}

/// A finished run run again printed "wrote 600 frames … 507453 images/s":
/// a rate over frames it did not make. It now says it was already complete.
#[test]
fn a_finished_run_run_again_says_already_complete() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write_preset(dir.path(), "tiny.ron", &common::tiny_preset());
    for (labels_only, nothing) in [(true, "nothing planned"), (false, "nothing rendered")] {
        let out_dir = dir.path().join(if labels_only { "plan" } else { "batch" });
        let run = || {
            let mut c = swarmshot();
            c.arg("batch").arg(&path).arg("--out").arg(&out_dir);
            if labels_only {
                c.arg("--labels-only");
            }
            let out = c.output().expect("runs");
            let text = String::from_utf8_lossy(&out.stdout).into_owned();
            assert!(
                out.status.success(),
                "{text}{}",
                String::from_utf8_lossy(&out.stderr)
            );
            text
        };
        let first = run();
        assert!(!first.contains("already complete"), "{first}");
        let again = run();
        assert!(
            again.starts_with("already complete: 8 frames (") && again.contains(nothing),
            "{again}"
        );
        assert!(!again.contains("/s"), "no rate: {again}");
    }
}
