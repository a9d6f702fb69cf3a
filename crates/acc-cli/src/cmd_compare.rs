//! `acc compare <scenario>`: run every baseline and our controller on the same scenario and
//! seed; print one table (force RMS error while cutting, peak force, time above 1.1·Fr,
//! cycle time, override switches), the oracle row (`acc_sim::oracle`: the lower bound of
//! a grid law with foresight) with every law's ratio to it, and draw an overlay plot of
//! force and override. With `--program` the laws run an NC program
//! ([`crate::cmd_compare_program`]).

use std::path::{Path, PathBuf};

use acc_core::Quantizer;
use acc_plot::{time_series, Figure, HLine, Panel, Series, Shade, Written};
use acc_sim::oracle::oracle;
use acc_sim::summary::{comparison_table, OracleFigures};
use acc_sim::{LawKind, RunResult, Scenario, Summary};
use anyhow::Context as _;

use crate::cmd_sim::{air_shades, default_out, load_scenario, pts};

/// Arguments of `acc compare`.
#[derive(Debug, clap::Args)]
pub struct CompareArgs {
    /// Scenario: a file, or a name in configs/scenarios (e.g. `paper_case3`).
    pub scenario: String,
    /// Output directory for the overlay plot (default `out/<scenario name>`).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Override the scenario's seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Do not draw the overlay plot.
    #[arg(long)]
    pub no_plot: bool,
    /// An NC program on a stock (`--program`, `--stock`, `--stock-box`, `--tools`): every
    /// law runs the program, without and with the plan's look-ahead, against the
    /// program's oracle (one table; no overlay plot).
    #[command(flatten)]
    pub program: crate::cmd_sim_program::ProgramArgs,
}

/// Run every law of [`LawKind::ALL`] on `sc`.
pub fn compare(sc: &Scenario) -> anyhow::Result<Vec<(RunResult, Summary)>> {
    LawKind::ALL
        .iter()
        .map(|&k| {
            let (mut r, mut s) = sc.run_law(k)?;
            if k == LawKind::Ours {
                // The scenario's own preset may itself be a baseline (the paper's fixed gains).
                r.law = format!("ours:{}", r.law);
                s.law.clone_from(&r.law);
            }
            Ok((r, s))
        })
        .collect()
}

/// Ours with each quantizer (`round`, `sigma_delta`) on `sc`, the preset's gains and board
/// step otherwise unchanged.
pub fn quantizer_runs(sc: &Scenario) -> anyhow::Result<Vec<(Quantizer, Summary)>> {
    [Quantizer::Round, Quantizer::SigmaDelta]
        .iter()
        .map(|&q| {
            let mut s = sc.clone();
            s.controller.override_spec = s
                .controller
                .override_spec
                .with_hysteresis(0.0)
                .with_quantizer(q);
            let (_, sum) = s.run_law(LawKind::Ours)?;
            Ok((q, sum))
        })
        .collect()
}

/// Settled mean force error per cut segment that reaches Fr, N (the summary's
/// `mean_error_n`, mean measured force − Fr after settling), in path order.
pub fn settled_errors(s: &Summary) -> Vec<f64> {
    s.segments
        .iter()
        .filter(|g| g.is_cut && g.reaches_ref && g.settled_periods > 0)
        .map(|g| g.mean_error_n)
        .collect()
}

/// The quantizer table of `acc compare`: per quantizer the settled mean force error per cut
/// segment (N and % of Fr, worst first), force RMS error while cutting, peak, cycle time and
/// override switches.
pub fn quantizer_table(rows: &[(Quantizer, Summary)]) -> String {
    let mut out = format!(
        "{:<12} {:>16} {:>12} {:>10} {:>9} {:>9}  settled mean error per segment [N]\n",
        "quantizer", "worst_settled_%Fr", "rms_err_N", "peak_F_N", "cycle_s", "switches"
    );
    for (q, s) in rows {
        let errs = settled_errors(s);
        let worst = errs.iter().fold(0.0f64, |m, e| m.max(e.abs()));
        let cycle = s
            .cycle_time_s
            .map_or_else(|| "unfinished".to_string(), |c| format!("{c:.1}"));
        let list: Vec<String> = errs.iter().map(|e| format!("{e:+.1}")).collect();
        out.push_str(&format!(
            "{:<12} {:>16.2} {:>12.1} {:>10.1} {:>9} {:>9}  {}\n",
            q.name(),
            100.0 * worst / s.force_ref_n,
            s.rms_error_cut_n,
            s.peak_force_n,
            cycle,
            s.override_switches,
            list.join(" ")
        ));
    }
    out
}

/// Run `acc compare`.
pub fn run_cmd(args: &CompareArgs) -> anyhow::Result<()> {
    let sc = load_scenario(&args.scenario, args.seed)?;
    if let Some(path) = crate::cmd_sim_program::load(&args.program, &sc)? {
        println!(
            "scenario: {} ({}), seed {}; program {}",
            sc.name,
            sc.path.display(),
            sc.seed,
            args.program
                .program
                .as_deref()
                .map_or_else(String::new, |p| p.display().to_string())
        );
        return crate::cmd_compare_program::run_cmd(&sc, &path);
    }
    let results = compare(&sc)?;
    println!(
        "scenario: {} ({}), seed {}",
        sc.name,
        sc.path.display(),
        sc.seed
    );
    println!(
        "constant-safe = {} % (the constant override keeping the deepest section at Fr)",
        sc.safe_override_pct()
    );
    let summaries: Vec<Summary> = results.iter().map(|(_, s)| s.clone()).collect();
    let fr = summaries
        .first()
        .map_or(sc.controller.force_ref_n, |s| s.force_ref_n);
    let orc = oracle(&sc, fr)?;
    print!(
        "{}",
        comparison_table(&summaries, Some(&OracleFigures::from(&orc)))
    );
    println!(
        "oracle: a grid law that knows the engagement ahead, on the noise-free plant (docs/sim.md); \
         rms: lowest force RMS error while cutting (its run: cycle {}); peak: lowest peak of a \
         law no slower than constant-safe ({}); cycle: fastest with no period above Fr \
         (peak {:.1} N)",
        orc.rms
            .cycle_time_s
            .map_or_else(|| "unfinished".to_string(), |c| format!("{c:.1} s")),
        if orc.peak_budget_s.is_finite() {
            format!("{:.1} s", orc.peak_budget_s)
        } else {
            "unfinished".to_string()
        },
        orc.safe.peak_force_n
    );
    let q = quantizer_runs(&sc)?;
    println!(
        "quantizer (ours, the preset's gains, board step {} %):",
        sc.controller.override_spec.step_pct
    );
    print!("{}", quantizer_table(&q));
    if summaries.iter().any(|s| s.feed_hold_at_s.is_some()) {
        println!(
            "hold@t: every law runs in the production loop; its fault policy held the feed at t s \
             (overload: above {:.0} N for {} s, the tool-breakage protection) and the run ended there",
            sc.policy.overload_force_n, sc.policy.overload_time_s
        );
    }
    if !args.no_plot {
        let out = args.out.clone().unwrap_or_else(|| default_out(&sc));
        std::fs::create_dir_all(&out)
            .with_context(|| format!("{}: cannot create", out.display()))?;
        let w = plot_overlay(&sc, &results, &out.join("compare.svg"))?;
        println!("plot: {} and {}", w.svg.display(), w.png.display());
    }
    Ok(())
}

/// Force and override of every law over time, one colour per law.
pub fn plot_overlay(
    sc: &Scenario,
    results: &[(RunResult, Summary)],
    out: &Path,
) -> anyhow::Result<Written> {
    // Each law reaches the air cuts at its own time: shade those of the slowest run and say
    // whose they are.
    let (longest, slowest) = results
        .iter()
        .max_by_key(|(r, _)| r.rows.len())
        .map_or((&[][..], ""), |(r, _)| (r.rows.as_slice(), r.law.as_str()));
    let shades: Vec<_> = air_shades(sc, longest)
        .into_iter()
        .map(|s| Shade {
            name: format!("air cut ({slowest})"),
            ..s
        })
        .collect();
    let force = results
        .iter()
        .map(|(r, _)| Series::line(&r.law, pts(&r.rows, |x| x.force_n)))
        .collect();
    let ov = results
        .iter()
        .map(|(r, _)| {
            Series::line(
                &r.law,
                pts(&r.rows, |x| {
                    x.override_cmd_pct.or(x.override_applied_pct).map(f64::from)
                }),
            )
        })
        .collect();
    let fig = Figure {
        title: format!("{} — all laws, seed {}", sc.name, sc.seed),
        x_label: "time [s]".into(),
        panels: vec![
            Panel {
                y_label: "force [N]".into(),
                series: force,
                hlines: vec![HLine::new("Fr", sc.controller.force_ref_n)],
                shades: vec![],
                y_range: None,
            },
            Panel {
                y_label: "override [%]".into(),
                series: ov,
                hlines: vec![],
                shades,
                y_range: None,
            },
        ],
        panel_height_px: 320,
        ..Figure::default()
    };
    Ok(time_series(&fig, out)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compare_runs_every_law_on_one_seed_and_draws_the_overlay() {
        let sc = load_scenario("paper_case4", None).expect("scenario");
        let results = compare(&sc).expect("compare");
        let names: Vec<&str> = results.iter().map(|(r, _)| r.law.as_str()).collect();
        assert_eq!(
            names,
            [
                "constant-feed",
                "constant-safe",
                "fixed-pi",
                "rate-limited",
                "proportional",
                "ours:adaptive-pi"
            ]
        );
        let summaries: Vec<Summary> = results.iter().map(|(_, s)| s.clone()).collect();
        let orc = oracle(&sc, summaries[0].force_ref_n).expect("oracle");
        let table = comparison_table(&summaries, Some(&OracleFigures::from(&orc)));
        assert_eq!(table.lines().count(), 8);
        assert!(table.lines().last().expect("row").starts_with("oracle"));
        assert!(table.lines().next().expect("header").contains("rms/oracle"));
        let dir = std::env::temp_dir().join(format!("acc-compare-cmd-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let w = plot_overlay(&sc, &results, &dir.join("compare.svg")).expect("plot");
        assert!(w.svg.is_file() && w.png.is_file());
        std::fs::remove_dir_all(&dir).ok();
    }
}
