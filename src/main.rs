//! The `swarmshot` command line: parses the arguments ([`cli::args`]) and
//! hands each command to its file in `cli/`; with no subcommand, the desktop
//! app opens. See `cli/mod.rs` for where each command lives.

use clap::Parser;

mod cli;
use cli::args::{BenchCommand, Cli, Command};

fn main() -> std::process::ExitCode {
    cli::process::start();
    cli::process::exit_code(run())
}

fn run() -> anyhow::Result<()> {
    let Some(command) = Cli::parse().command else {
        return cli::gui::run(None);
    };
    if !matches!(command, Command::Gui { .. }) {
        cli::process::quiet_headless_vulkan();
    }
    match command {
        Command::Gui { preset } => cli::gui::run(preset),
        Command::Batch(args) if args.labels_only => cli::plan::run(args),
        Command::Batch(args) => cli::batch::run(args),
        Command::Merge(args) => cli::reports::merge(args),
        Command::Check { preset } => cli::check::check(&preset),
        Command::Stats(args) => cli::reports::stats(args),
        Command::Gap(args) => cli::reports::gap(args),
        Command::Frame(args) => cli::frame::run(args),
        Command::Fit(args) => cli::fit::run(args),
        Command::Bench { which } => match which {
            BenchCommand::Accuracy(args) => cli::tools::bench_accuracy(&args),
            BenchCommand::Frames(args) => cli::tools::bench_frames(&args),
        },
        Command::Gallery(args) => cli::tools::gallery(&args),
        Command::Assets { dir } => cli::tools::assets(&dir),
    }
}
