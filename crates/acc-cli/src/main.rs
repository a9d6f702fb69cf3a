//! `acc`: adaptive feedrate-override control for CNC milling.

use clap::{Parser, Subcommand};

mod cmd_board_sim;
mod cmd_compare;
mod cmd_discrepancy;
mod cmd_estimate_eval;
mod cmd_fault_matrix;
mod cmd_run;
mod cmd_sim;
mod cmd_soak;
mod cmd_stability;
mod configs;
mod harness;

/// Adaptive feedrate-override control for CNC milling.
#[derive(Parser)]
#[command(name = "acc", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Closed-loop poles, damping, Kc ratio margin and fixed-gain stable range of a
    /// controller preset; `--plot` draws the pole map (SVG + PNG).
    Stability(cmd_stability::StabilityArgs),
    /// Accuracy of the spindle force estimators: simulated seed 000 sweep (table + Fig. 8
    /// plot), real turning data (MAPE vs dynamometer), wax milling (noise floor); or
    /// estimate from a sample stream (`--stream FILE|-`).
    EstimateEval(cmd_estimate_eval::EstimateEvalArgs),
    /// Run a scenario on the simulated machine: run log (CSV), per-segment summary, and the
    /// paper-style plot (force, override, feed, Kc_hat, Kp, Ki; SVG + PNG).
    Sim(cmd_sim::SimArgs),
    /// Run every baseline and our controller on one scenario and seed: one table (force RMS
    /// error, peak force, time above 1.1·Fr, cycle time, override switches) and an overlay plot.
    Compare(cmd_compare::CompareArgs),
    /// Compare a model with a measured run log (open-loop replay), name the missing
    /// effect, write report.json/.md, plots and model.updated.toml.
    Discrepancy(cmd_discrepancy::DiscrepancyArgs),
    /// The production loop against the PMC interface board (Modbus RTU): fault policy,
    /// operator priority, run log (CSV, same schema as `acc sim`). Ctrl-C mid-cut keeps
    /// control until the cut ends (at most `[shutdown] drain_s`), then releases; still
    /// cutting then, or a second Ctrl-C: feed hold, then release. Exit codes: 0 stopped out
    /// of the cut, 2 failure (config, file, link), 3 stopped mid-cut with feed hold, 4 the
    /// board's device vanished (port, cable, CAN interface).
    Run(cmd_run::RunArgs),
    /// Serve the board protocol on a new pty (prints its path) or a given port, backed by
    /// the simulated machine running in step with real time.
    BoardSim(cmd_board_sim::BoardSimArgs),
    /// The reliability fault matrix: every fault (signals, kill -9, hang, cable, device,
    /// board restart, CRC, late replies, stale or bad power, knob, lock, overload) driven at
    /// the deepest cut of a real `acc run` against `acc board-sim`, on a v2 and a v1 board;
    /// the table of override and force before/after, log completeness and exit codes.
    FaultMatrix(cmd_fault_matrix::FaultMatrixArgs),
    /// An hour of machine time (by default) of `acc run` against `acc board-sim` with a
    /// random board fault every few seconds: memory growth, lost rows, dead threads.
    Soak(cmd_soak::SoakArgs),
}

/// Exit code for a failed command (bad config, bad file, link error, ...).
const EXIT_FAILURE: i32 = 2;

fn main() {
    quiet_broken_pipe();
    let cli = Cli::parse();
    if let Err(e) = dispatch(cli) {
        // `{:#}` prints the whole cause chain on one line: the file, key and allowed range
        // that the config layers put into their errors.
        if let Some(x) = e.downcast_ref::<cmd_run::ExitWith>() {
            eprintln!("{x}");
            std::process::exit(x.code);
        }
        eprintln!("error: {e:#}");
        std::process::exit(EXIT_FAILURE);
    }
}

/// Output piped into a program that stops reading (`acc sim … | head`) is not an error:
/// exit quietly instead of panicking on the failed write to stdout.
fn quiet_broken_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if msg.contains("failed printing to stdout") && msg.contains("Broken pipe") {
            std::process::exit(0);
        }
        default(info);
    }));
}

fn dispatch(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Stability(args) => cmd_stability::run(&args),
        Command::EstimateEval(args) => cmd_estimate_eval::run(&args),
        Command::Sim(args) => cmd_sim::run_cmd(&args),
        Command::Compare(args) => cmd_compare::run_cmd(&args),
        Command::Run(args) => cmd_run::run_cmd(&args),
        Command::BoardSim(args) => cmd_board_sim::run_cmd(&args),
        Command::Discrepancy(args) => cmd_discrepancy::run(&args),
        Command::FaultMatrix(args) => cmd_fault_matrix::run_cmd(&args),
        Command::Soak(args) => cmd_soak::run_cmd(&args),
    }
}
