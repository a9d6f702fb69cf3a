//! `acc`: adaptive feedrate-override control for CNC milling.

use clap::{Parser, Subcommand};

/// Adaptive feedrate-override control for CNC milling.
#[derive(Parser)]
#[command(name = "acc", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {}
}
