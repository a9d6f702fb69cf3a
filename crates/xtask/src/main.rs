//! `xtask`: the development tasks of the `acc` repository, not part of the product.
//!
//! It regenerates the measured tables of `docs/reliability.md`: it runs the product's own
//! command (`acc fault-matrix` or `acc soak`, built with `cargo run --release -p acc-cli`)
//! with `--out out/<task>`, then splices the table the command wrote there into the doc,
//! between its markers (`splice::replace_between`). The shipped `acc` never writes into
//! the repository.
//!
//! ```sh
//! cargo run -p xtask -- fault-matrix-doc            # about 5½ minutes
//! cargo run -p xtask -- soak-doc                    # about 6 minutes
//! cargo run -p xtask -- fault-matrix-doc --only sigint --protocol 2
//! ```
//!
//! Arguments after the task go to the `acc` command unchanged (all but `--out`, which the
//! task sets). The table is spliced in even when rows fail, as the command prints it; the
//! task then fails with the command's exit status.
//!
//! `cargo run -p xtask -- deb [--bin PATH] [--out DIR]` builds the Debian package of
//! `acc` ([`deb`]).

mod deb;
mod splice;

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context};

/// One task: the `acc` subcommand it runs, its output folder under the repository, the
/// table file the subcommand writes there and the markers of the doc it goes between.
struct DocTable {
    /// `acc` subcommand.
    command: &'static str,
    /// The table file in the output folder.
    table: &'static str,
    /// The name of the doc's markers (`<!-- NAME:begin -->` … `<!-- NAME:end -->`).
    markers: &'static str,
}

/// The tasks: `fault-matrix-doc` and `soak-doc`.
const TASKS: [(&str, DocTable); 2] = [
    (
        "fault-matrix-doc",
        DocTable {
            command: "fault-matrix",
            table: "fault-matrix.md",
            markers: "fault-matrix",
        },
    ),
    (
        "soak-doc",
        DocTable {
            command: "soak",
            table: "soak.md",
            markers: "soak",
        },
    ),
];

/// The doc the tables go into, relative to the repository.
const DOC: &str = "docs/reliability.md";

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let names: Vec<&str> = TASKS.iter().map(|(n, _)| *n).collect();
    let Some(task) = args.next() else {
        bail!(
            "usage: cargo run -p xtask -- <{}|deb> [arguments]",
            names.join("|")
        );
    };
    if task == "deb" {
        let rest: Vec<String> = args.collect();
        return deb::run(&repository(), &rest);
    }
    let Some((_, doc_table)) = TASKS.iter().find(|(n, _)| *n == task) else {
        bail!("{task}: not a task; allowed: {}, deb", names.join(", "));
    };
    let rest: Vec<String> = args.collect();
    regenerate(&repository(), doc_table, &rest)
}

/// The repository's root (this crate is `crates/xtask`).
fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Run `acc <command> --out out/<command> <rest>` from the repository and splice the table
/// it wrote into [`DOC`].
fn regenerate(root: &Path, task: &DocTable, rest: &[String]) -> anyhow::Result<()> {
    if rest.iter().any(|a| a == "--out" || a.starts_with("--out=")) {
        bail!("--out: the task sets it (out/{})", task.command);
    }
    let out = Path::new("out").join(task.command);
    let table = root.join(&out).join(task.table);
    // A table left by an earlier run must not be taken for this one's.
    if table.exists() {
        std::fs::remove_file(&table).with_context(|| format!("{}", table.display()))?;
    }
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = Command::new(cargo)
        .current_dir(root)
        .args([
            "run",
            "--release",
            "-p",
            "acc-cli",
            "--",
            task.command,
            "--out",
        ])
        .arg(&out)
        .args(rest)
        .status()
        .context("starting `cargo run -p acc-cli`")?;
    if table.is_file() {
        let text =
            std::fs::read_to_string(&table).with_context(|| format!("{}", table.display()))?;
        splice::replace_between(&root.join(DOC), task.markers, &text)?;
        eprintln!(
            "xtask: {} written into {DOC}",
            out.join(task.table).display()
        );
    }
    if !status.success() {
        bail!("acc {} ended with {status}", task.command);
    }
    Ok(())
}
