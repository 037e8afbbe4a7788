//! The app in a real window (eframe + winit; on a machine without a display, under
//! Xvfb), driven from inside its own event loop: a measurement for docs/gui.md and
//! docs/benchmarks.md, not a test.
//!
//! - `batch PRESET OUT FRAMES`: once the first preview is on screen, press
//!   Generate for the first FRAMES frames into OUT (overwriting) and print the
//!   batch's own time (`BatchReport::elapsed`, as `swarmshot batch` prints it)
//!   and how many window passes ran meanwhile. Compare with
//!   `swarmshot batch PRESET --out OUT --limit FRAMES --overwrite` (issue 23: the
//!   GUI batch within 1.2× of the CLI).
//! - `latency PRESET [sky]`: 20 committed edits, one after another picture, each
//!   moving CameraZ's start (or, with `sky`, switching the procedural sky between
//!   two environments), and print the app's own measure ([`swarmshot::app::latency`],
//!   the status bar's "on screen … median of 20").
//!
//! - `start PRESET`: the time from the process's start to the window's first
//!   pass, and to the preset's first picture on screen (the start of the pass after
//!   the one that drew it), with the preview thread's render time of that picture and
//!   the window passes up to it with their repaint causes (it asks for no pass itself),
//!   and each pass's start with its causes and the input events it saw.
//!
//! Run (lavapipe, no display):
//! `xvfb-run -s "-screen 0 1920x1200x24" target/release/examples/app_bench latency presets/quickstart.ron`
//! (the window is 1656×900, so that the preview pane is 960×540 as in docs/gui.md).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;
use std::time::Instant;

use swarmshot::app::runner::BatchOutcome;
use swarmshot::app::{Command, StartOptions, SwarmshotApp};
use swarmshot::preset::Sky;
use swarmshot::sky::EnvironmentName;

const EDITS: usize = 20;

enum Mode {
    Batch {
        out: PathBuf,
        frames: u64,
    },
    Latency {
        sky: bool,
    },
    /// The process started at `t0`; eframe had the window and the GPU device at `made`.
    Start {
        t0: Instant,
        made: Instant,
    },
}

struct Bench {
    app: SwarmshotApp,
    mode: Mode,
    /// Batch: when Generate was pressed.
    started: Option<Instant>,
    /// Batch: window passes since Generate; start: passes up to the first picture.
    passes: u64,
    /// Why each of those window passes ran (egui's repaint causes).
    causes: std::collections::BTreeMap<String, u64>,
    /// Start: the pass that drew the first picture ran (the next pass sees it on screen).
    drawn: bool,
    /// Start: when the first pass began.
    first_pass: Option<Instant>,
    /// Start: each pass's start (ms from the process's start), causes and input events.
    pass_log: Vec<String>,
    /// Latency: edits made so far.
    edits: usize,
    done: bool,
}

impl Bench {
    fn batch_step(&mut self, ctx: &egui::Context) {
        let Mode::Batch { out, frames } = &self.mode else {
            return;
        };
        if self.started.is_none() {
            if !self.app.preview_is_current() {
                return;
            }
            let s = self.app.session_mut();
            s.out_dir = out.display().to_string();
            s.overwrite = true;
            s.trial = true;
            s.trial_frames = *frames;
            self.app.command(Command::Generate, ctx);
            self.started = Some(Instant::now());
            return;
        }
        self.passes += 1;
        for cause in ctx.repaint_causes() {
            *self.causes.entry(cause.to_string()).or_default() += 1;
        }
        if self.app.batch_running() {
            return;
        }
        println!("repaint causes during the batch: {:?}", self.causes);
        let wall = self.started.map_or(0.0, |t| t.elapsed().as_secs_f64());
        match self.app.batch_outcome() {
            Some(BatchOutcome::Done(report)) => println!(
                "gui batch: {} frames in {:.3} s (batch's own time; {wall:.3} s from Generate to the outcome), {} window passes meanwhile",
                report.stats.frames,
                report.elapsed.as_secs_f64(),
                self.passes
            ),
            Some(BatchOutcome::Failed(e)) => println!("gui batch failed: {e}"),
            None => println!("gui batch: no outcome"),
        }
        self.done = true;
    }

    /// Make the next edit once the last one's picture is on screen; true when it did.
    fn latency_step(&mut self) -> bool {
        let Mode::Latency { sky } = self.mode else {
            return false;
        };
        if !self.app.preview_is_current() || !self.app.preview_latency().idle() {
            return false;
        }
        if self.edits == EDITS + 1 {
            let recent: Vec<String> = self
                .app
                .preview_latency()
                .recent_ms()
                .map(|ms| format!("{ms:.0}"))
                .collect();
            let (median, n) = self.app.preview_latency().median_ms().unwrap_or((0.0, 0));
            let [w, h] = self.app.preview_key().map_or([0, 0], |k| k.size_px);
            println!(
                "latency ({}, preview {w}×{h}): median {median:.1} ms of {n}; last render {:.1} ms; all (ms): {}",
                if sky { "sky change" } else { "CameraZ edit" },
                self.app.preview_render_ms().unwrap_or(0.0),
                recent.join(" ")
            );
            self.done = true;
            return true;
        }
        // The first pass only waits for the start-up picture.
        if self.edits > 0 {
            let preset = &mut self.app.session_mut().preset;
            if sky {
                let name = if self.edits.is_multiple_of(2) {
                    EnvironmentName::ALL[0]
                } else {
                    EnvironmentName::ALL[1]
                };
                preset.sky = Sky::procedural(name);
            } else {
                preset.camera.z.start += if self.edits.is_multiple_of(2) {
                    -0.05
                } else {
                    0.05
                };
            }
        }
        self.edits += 1;
        true
    }
}

impl Bench {
    /// Start mode: print the times once the first picture is on screen, with
    /// the window passes before it and why each ran.
    fn start_step(&mut self, ctx: &egui::Context, pass: Instant) {
        let Mode::Start { t0, made } = self.mode else {
            return;
        };
        if self.done {
            return;
        }
        let first_pass = *self.first_pass.get_or_insert(pass);
        self.passes += 1;
        let mut these = std::collections::BTreeSet::new();
        for cause in ctx.repaint_causes() {
            *self.causes.entry(cause.to_string()).or_default() += 1;
            these.insert(short_cause(&cause.to_string()));
        }
        let at_ms = pass.duration_since(t0).as_secs_f64() * 1e3;
        let mut these: Vec<String> = these.into_iter().collect();
        ctx.input(|i| {
            for e in &i.raw.events {
                these.push(format!("{e:?}").chars().take(60).collect());
            }
        });
        (self.pass_log).push(format!("{at_ms:.0} ms [{}]", these.join(", ")));
        if self.drawn {
            println!(
                "start: {} window passes up to the picture on screen, repaint causes: {:?}",
                self.passes, self.causes
            );
            println!("start: the passes: {}", self.pass_log.join("; "));
            let ms = |t: Instant| t.duration_since(t0).as_secs_f64() * 1e3;
            let [w, h] = self.app.preview_key().map_or([0, 0], |k| k.size_px);
            println!(
                "start: window and GPU device ready {:.0} ms, first pass {:.0} ms, first picture on screen {:.0} ms (preview {w}×{h}, its render {:.0} ms)",
                ms(made),
                ms(first_pass),
                ms(pass),
                self.app.preview_render_ms().unwrap_or(0.0)
            );
            self.done = true;
        }
        self.drawn = self.app.preview_key().is_some();
        if self.drawn {
            // The next pass is the picture on screen: no wait for a poll.
            ctx.request_repaint();
        }
    }
}

impl eframe::App for Bench {
    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let pass = Instant::now();
        self.app.ui(ui, frame);
        self.start_step(&ctx, pass);
        if self.done {
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            return;
        }
        self.batch_step(&ctx);
        if self.latency_step() {
            // The app sees the edit in the next pass, which times it from its start.
            ctx.request_repaint();
        }
        // Otherwise the bench acts in the passes the app asks for itself: a
        // poll of its own would repaint the window and pace what is measured,
        // so there is none while the batch runs.
        // The start mode polls neither: the app's own wake-up brings its picture.
        if self.started.is_none() && !matches!(self.mode, Mode::Start { .. }) {
            ctx.request_repaint_after(std::time::Duration::from_millis(500));
        }
    }
}

/// A repaint cause as `file:line`, the file without its folders.
fn short_cause(cause: &str) -> String {
    let cause = cause.trim();
    cause.rsplit('/').next().unwrap_or(cause).to_owned()
}

fn main() -> eframe::Result<()> {
    let t0 = Instant::now();
    // SAFETY: the first thing main does, before any thread exists (as `swarmshot gui` does).
    #[allow(unsafe_code)]
    unsafe {
        swarmshot::app::quiet_vulkan_on_plain_x11()
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: app_bench batch PRESET OUT FRAMES | app_bench latency PRESET [sky] | app_bench start PRESET";
    let (mode, preset) = match args.first().map(String::as_str) {
        Some("batch") if args.len() == 4 => (
            Mode::Batch {
                out: PathBuf::from(&args[2]),
                frames: args[3].parse().expect(usage),
            },
            PathBuf::from(&args[1]),
        ),
        Some("latency") if args.len() >= 2 => (
            Mode::Latency {
                sky: args.get(2).is_some_and(|a| a == "sky"),
            },
            PathBuf::from(&args[1]),
        ),
        Some("start") if args.len() == 2 => (Mode::Start { t0, made: t0 }, PathBuf::from(&args[1])),
        _ => panic!("{usage}"),
    };
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default().with_inner_size([1656.0, 900.0]),
        renderer: eframe::Renderer::Wgpu,
        ..Default::default()
    };
    eframe::run_native(
        "swarmshot app_bench",
        options,
        Box::new(move |cc| {
            let mut mode = mode;
            if let Mode::Start { made, .. } = &mut mode {
                *made = Instant::now();
            }
            let app = SwarmshotApp::new(
                cc,
                StartOptions {
                    preset: Some(preset),
                    restore_session: false,
                },
            );
            Ok(Box::new(Bench {
                app,
                mode,
                started: None,
                passes: 0,
                causes: Default::default(),
                edits: 0,
                drawn: false,
                first_pass: None,
                pass_log: Vec::new(),
                done: false,
            }))
        }),
    )
}
