//! `rubscan` command line: parses arguments and dispatches to [`rubscan::app`].

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Critical-speed scans of a bladed impeller rubbing inside a flexible casing.
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Build or inspect reduced-order models.
    Model {
        #[command(subcommand)]
        action: ModelAction,
    },
}

#[derive(Subcommand)]
enum ModelAction {
    /// Build the impeller and casing ROMs of a model spec (JSON; omit for the built-in defaults).
    Build {
        /// Model spec (JSON). Without it, the built-in default models are built.
        spec: Option<PathBuf>,
        /// Output directory for `impeller.rom` and `casing.rom`.
        #[arg(short, long, default_value = "results/models")]
        output: PathBuf,
    },
    /// Print sizes, frequencies per nodal diameter and Ω dependence of a ROM file.
    Info {
        /// ROM file.
        file: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Model {
            action: ModelAction::Build { spec, output },
        } => rubscan::app::model_build(spec.as_deref(), &output),
        Command::Model {
            action: ModelAction::Info { file },
        } => rubscan::app::model_info(&file).map(|text| print!("{text}")),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
