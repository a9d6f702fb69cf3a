//! The plan follower on an NC program ([`acc_sim::plan_follower`]): the force RMS error a
//! law reaches that reads the plan with the tool's exact position and the plan's scale
//! known, and the periods where the plant's force exceeds 1.05 Fr (docs/plan.md, "What the
//! plan cannot see").
//!
//!     cargo run --release -p acc-sim --example plan_follower -- tests/nc/pocket_rect.ngc \
//!         -20,-20,-10,60,50,0 [--scale K] [--ceiling C] [--csv FILE]
//!
//! The scenario is `configs/scenarios/paper_case3.toml` with the program's stock on
//! 0.25 mm cells, as `acc sim paper_case3 --program … --stock-box …` runs it; the plan is
//! the one `acc plan` writes for it (`ProgramPath::plan`). `--scale` (default 1) is the
//! plan's scale `k`, `--ceiling` (default 1.03) the ceiling in Fr, `--csv` writes the
//! rows (`t_s, block, x_true_mm, override_pct, force_n, radial_depth_mm, axial_depth_mm`,
//! the force the period's true mean) to set against a run's `run.csv` or the oracle's
//! (`oracle_trace`) block by block.
use acc_sim::oracle::write_trace_csv;
use acc_sim::plan::PlanParams;
use acc_sim::plan_follower::{follow_plan, FollowerConfig};
use acc_sim::program::{ProgramPath, ProgramSpec, StockSource};
use acc_sim::Scenario;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [program, stock, rest @ ..] = &args[..] else {
        return Err("usage: plan_follower PROGRAM.ngc X0,Y0,Z0,X1,Y1,Z1 [--scale K] [--ceiling C] [--csv FILE]".into());
    };
    let base = Scenario::load(acc_sim::run::configs_dir().join("scenarios/paper_case3.toml"))?;
    let mut cfg = FollowerConfig::of(&base, 1.0);
    let mut csv = None;
    let mut it = rest.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str, lo: f64, hi: f64| -> Result<f64, String> {
            let v = it.next().ok_or(format!("{name}: a value is needed"))?;
            let x: f64 = v.parse().map_err(|e| format!("{name} `{v}`: {e}"))?;
            if (lo..=hi).contains(&x) {
                Ok(x)
            } else {
                Err(format!("{name} {x}: allowed {lo} ..= {hi}"))
            }
        };
        match a.as_str() {
            "--scale" => cfg.scale = value("--scale", 0.5, 2.0)?,
            "--ceiling" => cfg.ceiling = value("--ceiling", 0.5, 2.0)?,
            "--csv" => csv = Some(it.next().ok_or("--csv: a file is needed")?.clone()),
            other => return Err(format!("unknown option `{other}`").into()),
        }
    }
    let spec = ProgramSpec {
        program: program.into(),
        stock: StockSource::Box(stock.parse()?, 0.25),
        tools: None,
    };
    let path = ProgramPath::for_scenario(&spec, &base)?;
    let sc = path.scenario_for(&base);
    let plan = path.plan(&PlanParams::of(&sc));
    let run = follow_plan(&base, &path, &plan, cfg);
    let fr = sc.controller.force_ref_n;
    let cutting = run
        .rows
        .iter()
        .filter(|r| r.force_n.unwrap_or(0.0) > 0.05 * fr);
    println!(
        "plan follower (exact position, scale {}, ceiling {} Fr): force RMS error {:.1} N over {} rows, highest force {:.3} Fr, cycle {:.1} s{}",
        cfg.scale,
        cfg.ceiling,
        run.summary.rms_error_n,
        cutting.count(),
        run.peak_n() / fr,
        run.summary.cycle_s,
        if run.finished { "" } else { " (did not finish)" }
    );
    if let Some(out) = &csv {
        write_trace_csv(&run.rows, std::path::Path::new(out))?;
    }
    for r in run
        .rows
        .iter()
        .filter(|r| r.force_n.unwrap_or(0.0) > 1.05 * fr)
    {
        println!(
            "  above 1.05 Fr: t {:.1} s, block {}, path {:.3} mm, override {} %, force {:.0} N, radial {:.2} mm, axial {:.2} mm",
            r.t_s,
            r.block.unwrap_or(0),
            r.x_true_mm.unwrap_or(0.0),
            r.override_cmd_pct.unwrap_or(0),
            r.force_n.unwrap_or(0.0),
            r.radial_depth_mm.unwrap_or(0.0),
            r.axial_depth_mm.unwrap_or(0.0)
        );
    }
    Ok(())
}
