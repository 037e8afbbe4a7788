//! The commands that read what was written and report on it: `stats` (a
//! dataset's or plan's Table 2 and histograms), `gap` (the domain-gap report)
//! and `merge` (shards joined into one dataset).

use super::args::{GapArgs, MergeArgs, StatsArgs};

/// `swarmshot stats DIR`: the paper's Table 2 of a dataset or plan, and its histograms.
pub(crate) fn stats(args: StatsArgs) -> anyhow::Result<()> {
    use swarmshot::write::stats::{DEFAULT_PLOTS, check_plots_dir, open_plots_dir};
    let (dir, plots_arg, json) = (&args.dir, args.plots, args.json);
    let plots = (plots_arg.clone()).unwrap_or_else(|| dir.join(DEFAULT_PLOTS));
    check_plots_dir(dir, &plots)?;
    let stats = swarmshot::write::stats::read_dataset(dir)?;
    if json {
        println!("{}", serde_json::to_string_pretty(&stats)?);
        return Ok(());
    }
    // Opened before the table is printed: a folder that cannot take the PNGs stops it.
    let mut out = open_plots_dir(dir, plots_arg.as_deref())?;
    println!(
        "{} ({})",
        dir.display(),
        if stats.labels_only {
            "labels-only plan: no images"
        } else {
            "rendered dataset"
        }
    );
    println!("boxes: {}", stats.boxes_from);
    print!("{}", stats.table());
    for path in swarmshot::write::stats::write_histograms(&stats, &mut out)? {
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// `swarmshot gap --real REAL --synthetic DIR`: the domain-gap report.
pub(crate) fn gap(args: GapArgs) -> anyhow::Result<()> {
    let GapArgs {
        real,
        synthetic,
        out,
        max_images,
        json,
        real_classes,
        synthetic_classes,
    } = args;
    // An --out inside --real or --synthetic is refused before measuring.
    if let Some(out) = &out {
        swarmshot::gap::report::check_out(out, &[("real", &real), ("synthetic", &synthetic)])?;
    }
    let report = swarmshot::gap::run_report(&swarmshot::gap::GapOptions {
        real,
        synthetic,
        max_images,
        real_classes,
        synthetic_classes,
    })?;
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report.table());
    }
    if let Some(out) = &out {
        for path in report.write(out)? {
            eprintln!("wrote {}", path.display());
        }
    }
    Ok(())
}

/// `swarmshot merge OUT SHARD…`: the shards of one run joined into its dataset.
pub(crate) fn merge(args: MergeArgs) -> anyhow::Result<()> {
    let out = &args.out;
    super::process::check_open_files("merge")?;
    let t = std::time::Instant::now();
    let r = swarmshot::write::merge::merge(out, &args.shards, args.overwrite, args.copy)?;
    let s = &r.stats;
    // Every shard was already in OUT (a finished merge, or a finished batch
    // of the same run): nothing was joined now, so nothing is called merged.
    if r.shards_before == r.shards {
        println!(
            "already complete: {} holds all {} frames of these {} shards' run ({} train / {} val / {} test), {} boxes; nothing merged",
            out.display(),
            s.frames,
            r.shards,
            s.frames_per_split[0],
            s.frames_per_split[1],
            s.frames_per_split[2],
            s.boxes,
        );
        return Ok(());
    }
    let before = if r.shards_before > 0 {
        format!(
            " ({} joined by an earlier, interrupted merge)",
            r.shards_before
        )
    } else {
        String::new()
    };
    println!(
        "merged {} shards{before} into {}: {} frames ({} train / {} val / {} test), {} boxes; {} files hard-linked, {} copied, in {:.1} s",
        r.shards,
        out.display(),
        s.frames,
        s.frames_per_split[0],
        s.frames_per_split[1],
        s.frames_per_split[2],
        s.boxes,
        r.linked,
        r.copied,
        t.elapsed().as_secs_f64()
    );
    Ok(())
}
