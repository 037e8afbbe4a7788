//! The command line as clap parses it: the subcommands and, for each with
//! more than one flag, its flags as a named struct that its file in `cli/`
//! takes. Parsing only; `main.rs` dispatches.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};
use swarmshot::gap::folder::DroneClasses;

/// The most threads `--threads` accepts (encoder threads, or planning threads with --labels-only).
pub(crate) const MAX_THREADS: usize = 256;

/// The most makers `--makers` accepts (frames made at once, each with its
/// own renderer); the memory they need is checked too (`batch.rs`).
pub(crate) const MAX_MAKERS: usize = 64;

#[derive(Parser)]
#[command(
    name = "swarmshot",
    version,
    about = "Synthetic training data for UAV-swarm detection"
)]
pub(crate) struct Cli {
    /// With no subcommand, the desktop app opens.
    #[command(subcommand)]
    pub(crate) command: Option<Command>,
}

#[derive(Subcommand)]
pub(crate) enum Command {
    /// Open the desktop app (the default when no subcommand is given).
    Gui {
        /// A RON preset to open (default: the last session's preset).
        preset: Option<PathBuf>,
    },
    /// Render every frame of a preset into an image/label dataset.
    Batch(BatchArgs),
    /// Join the folders of `batch --shard K/N` runs into the dataset one
    /// process makes (images and labels hard-linked, COCO ids numbered on,
    /// manifests and statistics joined); run again after an interruption, it continues.
    Merge(MergeArgs),
    /// Validate a preset and print what it will make.
    Check { preset: PathBuf },
    /// The paper's Table 2 for a dataset or labels-only plan (images,
    /// resolution, instances, UAVs per image, small/medium/large) with
    /// per-split, per-model, per-environment and per-distance breakdowns,
    /// read from its manifest; writes histogram PNGs.
    Stats(StatsArgs),
    /// Make one frame alone, exactly as the batch writes it: the image (the
    /// preset's format and quality), its YOLO labels (.txt), its manifest
    /// record (.json) and the masks output.masks asks for (.seg.txt,
    /// .mask.png, .depth.png).
    Frame(FrameArgs),
    /// The domain-gap report: the same image statistics (noise, blur, gradients,
    /// edges, sky colour, brightness, drone size, contrast and polarity, JPEG quality)
    /// on a folder of real frames and on a swarmshot dataset, side by side with a verdict
    /// each and proposed camera-model ranges (docs/realism.md).
    Gap(GapArgs),
    /// Fit a preset to your own footage: the frames become backplates (labelled
    /// drones removed), the camera and the drones' size are fitted, and rounds of
    /// render → gap report → adjust run until the report puts the dataset inside the
    /// footage's range (docs/realism.md, "Fitting to your footage").
    Fit(FitArgs),
    /// Benchmarks that produce the tables in docs/ (run a release build).
    Bench {
        #[command(subcommand)]
        which: BenchCommand,
    },
    /// Regenerate the built-in models into assets/models/.
    Assets {
        #[arg(long, default_value = "assets/models")]
        dir: PathBuf,
    },
    /// Render the built-in models' contact sheet and one frame per named environment.
    Gallery(GalleryArgs),
}

#[derive(Subcommand)]
pub(crate) enum BenchCommand {
    /// Label error of each box method against a 4× id-pass reference, next to run time;
    /// then frame time by resolution × MSAA × passes on the quickstart scene.
    Accuracy(AccuracyArgs),
    /// Median ms per frame (render + labels, no encode) and peak RSS: 15 drones
    /// at 1080p and 4K, 1 500 drones at 1080p, and the peer scene.
    Frames(FramesArgs),
}

#[derive(Args)]
pub(crate) struct BatchArgs {
    /// The RON preset.
    pub(crate) preset: PathBuf,
    /// Output folder (created if missing).
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Make only the first N frames (with --every: the first N of those).
    #[arg(long)]
    pub(crate) limit: Option<u64>,
    /// A trial of every Kth frame: frames 0, K, 2K, … with their own
    /// indices and names, each byte-identical to the full run's frame of
    /// that index. --resume (or the same command again) continues the
    /// trial; --resume without --every keeps the earlier trial's K; a
    /// different K or --limit on the same folder is refused (--overwrite
    /// starts again). Not with --shard, --labels-only or sequence presets.
    #[arg(long, value_name = "K", conflicts_with = "labels_only")]
    pub(crate) every: Option<u64>,
    /// Delete an earlier run's own files in the folder and start again
    /// (files swarmshot did not write are kept). Also lets the batch write
    /// into a non-empty folder that holds no swarmshot run.
    #[arg(long, conflicts_with = "resume")]
    pub(crate) overwrite: bool,
    /// Continue an interrupted run in --out from its first incomplete
    /// frame (the preset must be the locked one; without --limit, the
    /// earlier run's frame count is kept). Rerunning the same command
    /// without --resume also continues it.
    #[arg(long)]
    pub(crate) resume: bool,
    /// Image encoder threads (default: one per spare core).
    #[arg(long, default_value_t = 0)]
    pub(crate) threads: usize,
    /// Frames made at once, each by its own renderer (default: 1 when frames share a background; when every frame draws a new one, 2 on a software rasteriser with more than 2 cores and 3/4 of the cores, at most 12, on a GPU); at most 64, and no more than the memory holds (each maker needs a frame's memory).
    #[arg(long, default_value_t = 0)]
    pub(crate) makers: usize,
    /// Print each stage's share of the time at the end.
    #[arg(long)]
    pub(crate) timings: bool,
    /// Plan only: every label from geometry, no rendering and no GPU;
    /// writes labels, COCO, manifest, stats and PLAN.txt but no images and
    /// no data.yaml (Visible boxes are estimated by amodal ones; see
    /// docs/datasets.md). --threads sets the planning threads.
    #[arg(long, conflicts_with = "makers")]
    pub(crate) labels_only: bool,
    /// Make only shard K of N (K from 0) of the frames, for `swarmshot
    /// merge` to join: K/N, or `auto` from a Slurm job array
    /// (SLURM_ARRAY_TASK_ID …), or `auto/N` in a Kubernetes Indexed Job
    /// (JOB_COMPLETION_INDEX). See docs/scale.md.
    #[arg(long, value_name = "K/N|auto|auto/N", conflicts_with = "labels_only")]
    pub(crate) shard: Option<String>,
}

#[derive(Args)]
pub(crate) struct MergeArgs {
    /// Output folder for the merged dataset (created if missing).
    pub(crate) out: PathBuf,
    /// The shard folders, every shard 0..N-1 of one run, in any order.
    #[arg(required = true)]
    pub(crate) shards: Vec<PathBuf>,
    /// Delete an earlier run's own files in OUT and start again.
    #[arg(long)]
    pub(crate) overwrite: bool,
    /// Copy the shards' files instead of hard-linking them (later edits
    /// to a shard then cannot change the merged dataset).
    #[arg(long)]
    pub(crate) copy: bool,
}

#[derive(Args)]
pub(crate) struct StatsArgs {
    /// The dataset folder (`swarmshot batch --out`, with or without --labels-only).
    pub(crate) dir: PathBuf,
    /// Where the histogram PNGs go (default: DIR/stats-plots).
    #[arg(long)]
    pub(crate) plots: Option<PathBuf>,
    /// Print the statistics as JSON (the numbers of the batch's stats.json) instead.
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(Args)]
pub(crate) struct FrameArgs {
    pub(crate) preset: PathBuf,
    /// Frame index (0-based).
    #[arg(long, default_value_t = 0)]
    pub(crate) index: u64,
    /// Output image; its extension must match the preset's image format
    /// (.jpg for JPEG, .png for PNG). The labels go beside it.
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Draw the label boxes on the image (the image then differs from the batch's).
    #[arg(long)]
    pub(crate) overlay: bool,
    /// Replace the files the frame writes where they exist (without it an
    /// existing one is refused; the preset and the files it reads never are).
    #[arg(long)]
    pub(crate) overwrite: bool,
}

#[derive(Args)]
pub(crate) struct GapArgs {
    /// Folder of real frames (JPEG/PNG, searched 8 levels deep; YOLO labels found as
    /// Ultralytics finds them, images/ → labels/, or beside each frame; boxes, predictions,
    /// segmentation polygons and oriented boxes; docs/realism.md).
    #[arg(long)]
    pub(crate) real: PathBuf,
    /// A swarmshot dataset folder (`swarmshot batch --out`).
    #[arg(long)]
    pub(crate) synthetic: PathBuf,
    /// Write report.json, report.txt and histogram PNGs here (created if missing).
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// At most N frames per side, evenly spaced in name order (0: all).
    #[arg(long, default_value_t = 200)]
    pub(crate) max_images: usize,
    /// Print the report as JSON instead of the table.
    #[arg(long)]
    pub(crate) json: bool,
    /// The real labels' classes that are drones: class ids (0,2) or all; rows of other
    /// classes (birds, aircraft) are not measured.
    #[arg(long, default_value = "all", value_parser = parse_classes)]
    pub(crate) real_classes: DroneClasses,
    /// The dataset's classes that are drones (default: its preset's models' classes, not
    /// those of labelled confusers).
    #[arg(long, value_parser = parse_classes)]
    pub(crate) synthetic_classes: Option<DroneClasses>,
}

/// A `--…-classes` value: class ids separated by commas, or `all`.
fn parse_classes(text: &str) -> Result<DroneClasses, String> {
    DroneClasses::parse(text)
}

#[derive(Args)]
pub(crate) struct FitArgs {
    /// A folder of real frames (JPEG/PNG, searched 8 levels deep; YOLO labels found as
    /// Ultralytics finds them, images/ → labels/, or beside each frame; boxes, predictions,
    /// segmentation polygons and oriented boxes; docs/realism.md), or a video file
    /// (decoded by ffmpeg from PATH).
    #[arg(long)]
    pub(crate) real: PathBuf,
    /// Output folder: plates/, fitted.ron, footage.json, fit.json, rounds/NN/.
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// The preset the fit starts from [default: presets/realistic.ron, from the
    /// working folder or else from the repository swarmshot was built from].
    #[arg(long)]
    pub(crate) base: Option<PathBuf>,
    /// Frames rendered per round.
    #[arg(long, default_value_t = 64)]
    pub(crate) sample: u64,
    /// Fitted rounds at most (0: plates and the first fit only, no rendering).
    #[arg(long, default_value_t = 4)]
    pub(crate) rounds: usize,
    /// Use frames without labels (drones in them, if any, stay in the plates unlabelled).
    #[arg(long)]
    pub(crate) unlabelled_ok: bool,
    /// Replace an earlier fit's files in --out.
    #[arg(long)]
    pub(crate) overwrite: bool,
    /// At most N real frames, evenly spaced in name order (0: all).
    #[arg(long, default_value_t = 200)]
    pub(crate) max_frames: usize,
    /// The footage's horizontal field of view, degrees (default: from the base preset).
    #[arg(long)]
    pub(crate) hfov: Option<f64>,
    /// Frames per second taken from a video.
    #[arg(long, default_value_t = 2.0)]
    pub(crate) video_fps: f64,
    /// Plates per frame: 1 the frame alone; up to 9, the frame and crops of 80 % of it
    /// at shifted places (each with its own field of view and horizon).
    #[arg(long, default_value_t = 1)]
    pub(crate) views: usize,
    /// The labels' classes that are drones: class ids (0,2) or all; rows of other classes
    /// (birds, aircraft) stay in the plates and are not measured.
    #[arg(long, default_value = "all", value_parser = parse_classes)]
    pub(crate) classes: DroneClasses,
}

#[derive(Args)]
pub(crate) struct GalleryArgs {
    /// Output folder for models.png, confusers.png and env-NAME.jpg.
    #[arg(long, default_value = "docs/img")]
    pub(crate) out: PathBuf,
    /// Environment frame size.
    #[arg(long, default_value_t = 480)]
    pub(crate) width: u32,
    #[arg(long, default_value_t = 270)]
    pub(crate) height: u32,
    /// Instead of pictures: median 1080p frame time, gradient sky vs each environment.
    #[arg(long)]
    pub(crate) bench: bool,
}

#[derive(Args)]
pub(crate) struct AccuracyArgs {
    /// Frames per scene family.
    #[arg(long, default_value_t = 12)]
    pub(crate) frames: u32,
    #[arg(long, default_value_t = 960)]
    pub(crate) width: u32,
    #[arg(long, default_value_t = 540)]
    pub(crate) height: u32,
    /// Where to write the error-against-time plot (PNG).
    #[arg(long, default_value = "docs/img/accuracy.png")]
    pub(crate) plot: PathBuf,
    /// Frames timed per resolution × MSAA × passes cell.
    #[arg(long, default_value_t = 9)]
    pub(crate) timing_frames: u64,
}

#[derive(Args)]
pub(crate) struct FramesArgs {
    /// At most this many frames per scene (default: every frame of the
    /// 15-drone and peer scenes, 12 of the 1 500-drone one); the first,
    /// which builds pipelines, is left out of the median.
    #[arg(long)]
    pub(crate) frames: Option<u64>,
    /// The peer scene's preset (skipped when its files are missing).
    #[arg(long, default_value = "presets/bench/peer.ron")]
    pub(crate) peer: PathBuf,
    /// Time only the scenes whose name contains this text (e.g. "1 500", "3840", "peer").
    #[arg(long)]
    pub(crate) scene: Option<String>,
}
