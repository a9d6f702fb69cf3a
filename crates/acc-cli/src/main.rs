//! `acc`: adaptive feedrate-override control for CNC milling.

use clap::{Parser, Subcommand};

mod cmd_board_sim;
mod cmd_collect;
mod cmd_compare;
mod cmd_compare_program;
mod cmd_discrepancy;
mod cmd_discrepancy_program;
mod cmd_estimate_eval;
mod cmd_history;
mod cmd_linuxcnc;
mod cmd_nc;
mod cmd_optimize;
mod cmd_plan;
mod cmd_report;
mod cmd_run;
mod cmd_sim;
mod cmd_sim_program;
mod cmd_stability;
mod cmd_what_if;
mod configs;
mod exit;
mod fleet_cli;
mod telemetry;
mod watch_cli;

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
    /// The cutting plan of an NC program on a stock: per block and engagement change the
    /// engagement, the predicted force at 100 %, the override that gives Fr and the path
    /// position (plan.csv), a plot of the force along the program and a summary.
    Plan(cmd_plan::PlanArgs),
    /// The program with its F words rewritten per block from the plan (blocks split where
    /// the engagement changes) so that the predicted force stays at or below Fr and air
    /// moves run at the tool's air feed; the predicted cycle time before and after.
    Optimize(cmd_optimize::OptimizeArgs),
    /// Run every baseline and our controller on one scenario and seed: one table (force RMS
    /// error, peak force, time above 1.1·Fr, cycle time, override switches) and an overlay plot.
    Compare(cmd_compare::CompareArgs),
    /// Compare a model with a measured run log (open-loop replay), name the missing
    /// effect, write report.json/.md, plots and model.updated.toml.
    Discrepancy(cmd_discrepancy::DiscrepancyArgs),
    /// What-if on a recorded cut: the production loop with another preset (gains, Fr,
    /// override limits, quantizer) closed loop on the twin whose cut geometry comes from
    /// the run log; recorded and what-if side by side (table, overlay plot). `acc replay`
    /// is a deprecated alias of this command, kept for one release.
    #[command(alias = "replay")]
    WhatIf(cmd_what_if::WhatIfArgs),
    /// The production loop against the PMC interface board (Modbus RTU): fault policy,
    /// operator priority, run log (CSV, same schema as `acc sim`). Ctrl-C mid-cut keeps
    /// control until the cut ends (at most `[shutdown] drain_s`), then releases; still
    /// cutting then, or a second Ctrl-C: feed hold, then release. One exit code per way the
    /// run ended (listed below).
    #[command(after_help = exit::RunExit::help())]
    Run(cmd_run::RunArgs),
    /// One command for LinuxCNC: writes the INI, HAL file and UI script of
    /// `configs/linuxcnc/` into `--out`, runs the program on headless LinuxCNC with
    /// `acc run --hal` and the simulated process, stops everything and summarizes (peak
    /// true force against Fr, log rows, cycle time). As root, realtime runs as `nobody`.
    Linuxcnc(cmd_linuxcnc::LinuxcncArgs),
    /// The simulated cutting process as a LinuxCNC HAL component (`acc-process`): follows
    /// LinuxCNC's axis positions, feed and spindle speed, cuts the Z-map stock, puts the
    /// spindle's electrical power on `acc-process.spindle-power` and writes a machine log.
    LinuxcncProcess(cmd_linuxcnc::process::ProcessArgs),
    /// Serve the board protocol on a new pty (prints its path) or a given port, backed by
    /// the simulated machine running in step with real time.
    BoardSim(cmd_board_sim::BoardSimArgs),
    /// The reliability fault matrix: every fault (signals, kill -9, hang, cable, device,
    /// board restart, CRC, late replies, stale or bad power, knob, lock, overload) driven at
    /// the deepest cut of a real `acc run` against `acc board-sim`, on a v2 and a v1 board;
    /// the table of override and force before/after, log completeness and exit codes.
    FaultMatrix(acc_harness::fault_matrix::FaultMatrixArgs),
    /// An hour of machine time (by default) of `acc run` against `acc board-sim` with a
    /// random board fault every few seconds: memory growth, lost rows, dead threads.
    Soak(acc_harness::soak::SoakArgs),
    /// One self-contained HTML page of a run log: force along the path with Fr and limit
    /// lines, override (commanded/applied), Kc_hat trend, the per-cut table (tool, program,
    /// blocks, time in cut, force statistics, override histogram, alarms, time saved) and
    /// the alarms. Opens with no network access.
    Report(cmd_report::ReportArgs),
    /// Interpret an NC program (RS274/NGC, common Fanuc words): one row per motion (line,
    /// N, kind, end point, feed, length, tool) and a summary (blocks, feed and rapid length,
    /// time at programmed feed). Errors name file:line:column, the word and what is allowed.
    Nc(cmd_nc::NcArgs),
    /// The fleet store (`--fleet` of `acc sim` / `acc run`, `acc collect`): `acc history
    /// query DIR "SQL"` runs SQL over its tables `period` and `cut` (embedded DataFusion).
    History(cmd_history::HistoryArgs),
    /// Write the fleet store from MQTT: subscribes to `PREFIX/+/period` and `PREFIX/+/cut`
    /// (`+` = machine id) and commits them as the same Parquet partitions as `--fleet`.
    Collect(cmd_collect::CollectArgs),
}

/// Exit code for a failed command other than `acc run` (bad config, bad file, ...).
const EXIT_FAILURE: i32 = 2;

fn main() {
    quiet_broken_pipe();
    let cli = Cli::parse();
    let is_run = matches!(cli.command, Command::Run(_));
    // A panic on the main thread is an internal error (exit 1), not a crash code.
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| dispatch(cli)))
        .unwrap_or_else(|_| Err(anyhow::anyhow!("internal error: the command panicked")));
    match result {
        Ok(()) => {
            if is_run {
                println!("{}", exit::RunExit::Completed.last_line());
            }
        }
        Err(e) if is_run => {
            // `acc run`: the error (the file, key, value and range from the config layers, on
            // one line with `{:#}`), then the last line saying which way the run ended.
            let how = exit::exit_of(&e);
            if let Some(x) = e.downcast_ref::<cmd_run::ExitWith>() {
                eprintln!("{x}");
            } else {
                eprintln!("error: {e:#}");
            }
            eprintln!("{}", how.last_line());
            std::process::exit(how.code());
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            let internal = e.to_string().starts_with("internal error");
            std::process::exit(if internal {
                exit::RunExit::Internal.code()
            } else {
                EXIT_FAILURE
            });
        }
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
        Command::Plan(args) => cmd_plan::run_cmd(&args),
        Command::Optimize(args) => cmd_optimize::run_cmd(&args),
        Command::Compare(args) => cmd_compare::run_cmd(&args),
        Command::WhatIf(args) => cmd_what_if::run_cmd(&args),
        Command::Run(args) => cmd_run::run_cmd(&args),
        Command::BoardSim(args) => cmd_board_sim::run_cmd(&args),
        Command::Linuxcnc(args) => cmd_linuxcnc::run_cmd(&args),
        Command::LinuxcncProcess(args) => cmd_linuxcnc::process::run_cmd(&args),
        Command::Discrepancy(args) => cmd_discrepancy::run(&args),
        Command::FaultMatrix(args) => acc_harness::fault_matrix::run(&args),
        Command::Soak(args) => acc_harness::soak::run(&args),
        Command::Report(args) => cmd_report::run(&args),
        Command::Nc(args) => cmd_nc::run(&args),
        Command::History(args) => cmd_history::run(&args),
        Command::Collect(args) => cmd_collect::run(&args),
    }
}

#[cfg(test)]
mod tests {
    /// Every subcommand's arguments are consistent (ids named by `conflicts_with` and
    /// `requires` exist, no two options share a name): clap checks it here once, not at a
    /// user's first call.
    #[test]
    fn the_command_line_definition_is_consistent() {
        use clap::CommandFactory as _;
        super::Cli::command().debug_assert();
    }
}
