//! `swarmshot fit --real REAL --out FIT`: a preset fitted to the user's footage.

use swarmshot::render::GpuContext;

use super::args::FitArgs;
use super::console::stop_on_signals;

/// `swarmshot fit`: the footage read and checked (nothing written before), plates and
/// the first fit written, then the rounds on the GPU, `fitted.ron` and the before/after.
pub(crate) fn run(args: FitArgs) -> anyhow::Result<()> {
    let options = swarmshot::fit::FitOptions {
        real: args.real,
        out: args.out,
        base: args.base.unwrap_or_else(swarmshot::fit::default_base),
        sample: args.sample,
        rounds: args.rounds,
        unlabelled_ok: args.unlabelled_ok,
        overwrite: args.overwrite,
        max_frames: args.max_frames,
        hfov_deg: args.hfov,
        video_fps: args.video_fps,
        views: args.views,
        classes: args.classes,
    };
    if options.sample == 0 {
        anyhow::bail!("--sample 0: a round needs at least 1 frame");
    }
    let started = std::time::Instant::now();
    let prep = swarmshot::fit::prepare(&options)?;
    let f = &prep.footage;
    let count = |n: usize, one, many| swarmshot::text::plural(n as u64, one, many);
    eprintln!(
        "read {} ({} labelled, {}) in {:.1} s; {} in {}",
        count(f.frames, "frame", "frames"),
        f.labelled_frames,
        count(f.drones, "drone", "drones"),
        started.elapsed().as_secs_f64(),
        count(prep.plates.plates.len(), "plate", "plates"),
        options.out.join("plates").display()
    );
    for warning in prep.warnings() {
        eprintln!("warning: {warning}");
    }
    let ctx = if options.rounds > 0 {
        Some(GpuContext::headless()?)
    } else {
        None
    };
    let cancel = stop_on_signals()?;
    let done = swarmshot::fit::finish(&prep, ctx.as_ref(), &cancel, &mut |line| {
        eprintln!("{line}")
    })?;
    if let Some(before) = &done.before {
        println!("== before: the base preset (round 00) ==\n{before}");
    }
    if let Some(after) = &done.after {
        println!(
            "== after: the fitted preset (round {:02}) ==\n{after}",
            done.record.best_round.unwrap_or(0)
        );
    }
    let summary: Vec<String> = (done.record.rounds.iter())
        .map(|r| format!("{:02}: {}/{}", r.round, r.inside, r.applicable))
        .collect();
    println!(
        "wrote {} in {:.1} s{}",
        done.fitted.display(),
        started.elapsed().as_secs_f64(),
        if summary.is_empty() {
            String::new()
        } else {
            format!(" (statistics inside per round: {})", summary.join(", "))
        }
    );
    Ok(())
}
