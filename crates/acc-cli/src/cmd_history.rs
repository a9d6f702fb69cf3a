//! `acc history query DIR "SQL"`: SQL over a fleet store with embedded DataFusion.

use std::path::PathBuf;

/// `acc history` arguments.
#[derive(clap::Args, Debug)]
pub struct HistoryArgs {
    #[command(subcommand)]
    pub command: HistoryCommand,
}

/// `acc history` subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum HistoryCommand {
    /// Run SQL over a fleet store: tables `period` (one row per control period) and `cut`
    /// (one row per cut), with `machine` and `date` as columns; an aligned table, or CSV.
    Query {
        /// The fleet store (`--fleet DIR` of `acc sim` / `acc run`, `--out` of `acc collect`).
        dir: PathBuf,
        /// The query, e.g. `SELECT machine, count(*) FROM period GROUP BY machine`.
        sql: String,
        /// Print CSV (header line, nulls empty) instead of the table.
        #[arg(long)]
        csv: bool,
    },
}

/// Run `acc history`.
pub fn run(args: &HistoryArgs) -> anyhow::Result<()> {
    match &args.command {
        HistoryCommand::Query { dir, sql, csv } => {
            print!("{}", acc_fleet::query::query_text(dir, sql, *csv)?);
            Ok(())
        }
    }
}
