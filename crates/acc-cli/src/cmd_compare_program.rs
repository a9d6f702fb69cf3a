//! `acc compare <scenario> --program part.ngc --stock-box …`: every law of `acc compare` on
//! an NC program, each without and with the plan's look-ahead, against the program's
//! oracle (`acc_sim::oracle_program`, docs/programs.md "The oracle of a program"): one
//! table of force RMS error, peak and cycle with each one's ratio to the oracle's.

use acc_sim::oracle::OraclePlant as _;
use acc_sim::oracle_program::{peak_n, program_oracle, ratio, run_program, ProgramPlant};
use acc_sim::plan::PlanParams;
use acc_sim::program::ProgramPath;
use acc_sim::program_summary::summarize_program;
use acc_sim::{LawKind, Scenario};

/// Run every law on `path` (with `base`'s machine, controller and channel) and print the
/// table with the oracle's row.
pub fn run_cmd(base: &Scenario, path: &ProgramPath) -> anyhow::Result<()> {
    let sc = path.scenario_for(base);
    let fr = sc.controller.force_ref_n;
    let plant = ProgramPlant::new(base, path);
    let o = program_oracle(&plant)?;
    let o_rms = o.rms.summary.rms_error_n;
    let o_cycle = ProgramPlant::cycle_s(&o.safe);
    let plan = path.plan(&PlanParams::of(&sc));
    println!(
        "program constant safe feed: {} % (the one override on the grid whose predicted peak is <= Fr)",
        plant.safe_pct()
    );
    println!("| law | look-ahead | force RMS error [N] | peak force [N] | cycle [s] | rms/oracle | peak/oracle | cycle/oracle |");
    println!("| --- | --- | --- | --- | --- | --- | --- | --- |");
    for law in LawKind::ALL {
        for with_plan in [false, true] {
            let mut l = path.build_law(&sc, law)?;
            let r = run_program(&sc, path, l.as_mut(), with_plan.then(|| plan.clone()))?;
            let s = summarize_program(&r.rows, fr, sc.controller.period_s);
            let cycle = r.finished.then_some(s.cycle_s);
            println!(
                "| {} | {} | {:.1} | {:.1} | {} | {} | {} | {} |",
                r.law,
                if with_plan { "plan" } else { "-" },
                s.rms_error_n,
                peak_n(&s),
                cycle.map_or_else(
                    || format!("{:.1} (did not finish)", s.cycle_s),
                    |c| format!("{c:.1}")
                ),
                // A run that stopped early did not cut the part: no ratio to a bound.
                ratio(r.finished.then_some(s.rms_error_n), Some(o_rms)),
                ratio(r.finished.then_some(peak_n(&s)), o.peak_n),
                ratio(cycle, o_cycle),
            );
        }
    }
    println!(
        "| *oracle* | knows the engagement | *{o_rms:.1}* | *{}* | *{}* | 1.00 | 1.00 | 1.00 |",
        o.peak_n.map_or_else(|| "-".into(), |p| format!("{p:.1}")),
        o_cycle.map_or_else(|| "-".into(), |c| format!("{c:.1}")),
    );
    println!(
        "oracle: a grid law that knows the engagement ahead, on the noise-free plant (docs/programs.md); \
         rms: lowest force RMS error while cutting{}; peak: lowest peak of a law no slower than the \
         constant safe feed; cycle: fastest with no row above Fr. Ratios only for runs that reach \
         the end of the program.",
        if o.rms.finished { "" } else { " (its run does not reach the end of the program)" }
    );
    Ok(())
}
