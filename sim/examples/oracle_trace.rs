//! The oracle held to a force ceiling on an NC program, period by period: writes each run
//! of its search as CSV (the per-period run, then each Dinkelbach step's) so that a law's
//! `run.csv` can be set against it block by block (docs/plan.md, "The plan's lead").
//!
//!     cargo run -p acc-sim --example oracle_trace -- tests/nc/pocket_rect.ngc \
//!         -20,-20,-10,60,50,0 out/oracle-pocket [CEILING × Fr, default 1.05] [--per-override]
//!
//! `--per-override`: no override whose force over a whole period is above the ceiling
//! either (`acc_sim::oracle_program::program_rms_within`), the plan's lead's rule.
//!
//! The scenario is `configs/scenarios/paper_case3.toml` with the program's stock on
//! 0.25 mm cells, as `acc sim paper_case3 --program … --stock-box …` runs it. Columns of
//! `oracle-K.csv`: `t_s, block, x_true_mm, override_pct, force_n, radial_depth_mm,
//! axial_depth_mm` (the force is the period's true mean).
use acc_sim::oracle::write_trace_csv;
use acc_sim::oracle_program::{program_rms_within_runs, ProgramPlant};
use acc_sim::program::{ProgramPath, ProgramSpec, StockSource};
use acc_sim::program_summary::summarize_program;
use acc_sim::Scenario;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let per_override = args.iter().any(|a| a == "--per-override");
    let args: Vec<&String> = args.iter().filter(|a| *a != "--per-override").collect();
    let [program, stock, out, rest @ ..] = &args[..] else {
        return Err(
            "usage: oracle_trace PROGRAM.ngc X0,Y0,Z0,X1,Y1,Z1 OUT_DIR [CEILING] [--per-override]"
                .into(),
        );
    };
    let ceiling: f64 = match rest.first() {
        Some(c) => c.parse().map_err(|e| format!("ceiling `{c}`: {e}"))?,
        None => 1.05,
    };
    if !(0.5..=2.0).contains(&ceiling) {
        return Err(format!("ceiling {ceiling}: allowed 0.5 ..= 2 (× Fr)").into());
    }
    let base = Scenario::load(acc_sim::run::configs_dir().join("scenarios/paper_case3.toml"))?;
    let spec = ProgramSpec {
        program: (*program).into(),
        stock: StockSource::Box(stock.parse()?, 0.25),
        tools: None,
    };
    let path = ProgramPath::for_scenario(&spec, &base)?;
    let sc = path.scenario_for(&base);
    let fr = sc.controller.force_ref_n;
    let plant = ProgramPlant::new(&sc, &path);
    let runs = program_rms_within_runs(&plant, ceiling, 3, per_override)?;
    std::fs::create_dir_all(out)?;
    for (k, r) in runs.iter().enumerate() {
        let s = summarize_program(&r.rows, fr, sc.controller.period_s);
        println!(
            "{}: force RMS error {:.1} N over {} rows, cycle {:.1} s{}",
            if k == 0 {
                "per period".to_string()
            } else {
                format!("Dinkelbach step {k}")
            },
            s.rms_error_n,
            r.rows.len(),
            s.cycle_s,
            if r.finished { "" } else { " (did not finish)" }
        );
        write_trace_csv(
            &r.rows,
            &std::path::Path::new(out).join(format!("oracle-{k}.csv")),
        )?;
    }
    Ok(())
}
