//! The full hidden-effect sweep of the model-discrepancy workflow: every candidate effect
//! hidden in simulated logs over seeds and effect-to-noise ratios, plus pairs (the fast grid
//! runs in `cargo test`):
//!
//! ```text
//! cargo run --release -p acc-ident --example twin_lab -- sweep [--seeds 20] [--enr 1,2,4,8] [--fdr 200] [--pairs 10] [--threads 2] [--effects a,b] [--out out/sweep]
//! ```
//!
//! For every candidate effect, effect-to-noise ratio (ENR, see `synth::effect_to_noise`),
//! noise kind (white, AR(1) ρ = 0.6) and seed: a synthetic log with the effect hidden,
//! the nominal model without it, the workflow. Prints the confusion matrix at ENR ≥ 4,
//! recovery (exactly the right effect named) against ENR, interval coverage and the
//! sealed-part gap closed, two hidden effects at once for confusable pairs, then the
//! false-discovery rate on logs with no hidden effect. The same tables go to
//! `<out>/sweep.md`, the recovery-versus-size curves to `<out>/recovery.svg` / `.png`.

use std::collections::BTreeMap;
use std::sync::Mutex;

use acc_ident::synth::{self, Case, Hidden, Outcome};
use acc_ident::{workflow, EffectKind};
use indicatif::{ProgressBar, ProgressStyle};

/// Print a line and keep it for `sweep.md`.
macro_rules! out {
    ($md:expr, $($t:tt)*) => {{
        let line = format!($($t)*);
        println!("{line}");
        $md.push_str(&line);
        $md.push('\n');
    }};
}

struct Job {
    kind: Option<EffectKind>,
    second: Option<EffectKind>,
    enr: f64,
    rho: f64,
    seed: u64,
}

fn arg<T: std::str::FromStr>(name: &str, default: T) -> T {
    let args: Vec<String> = crate::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Confusable pairs hidden together (each effect sized alone to ENR 6).
const PAIRS: [(EffectKind, EffectKind); 4] = [
    (EffectKind::ToolWear, EffectKind::NoloadDrift),
    (EffectKind::FeedDriveLag, EffectKind::SensorLowpass),
    (EffectKind::FeedDriveLag, EffectKind::OverrideDeadTime),
    (EffectKind::MotorEfficiency, EffectKind::FeedExponent),
];

fn case(rho: f64) -> Case {
    Case {
        duration_s: 120.0,
        rpm: 450.0,
        noise_rho: rho,
        ..Case::default()
    }
}

pub fn main() {
    let seeds: u64 = arg("--seeds", 20);
    let fdr: u64 = arg("--fdr", 200);
    let threads: usize = arg("--threads", 2);
    let enrs: Vec<f64> = arg("--enr", "1,2,4,8".to_string())
        .split(',')
        .filter_map(|s| s.parse().ok())
        .collect();
    // `--effects a,b`: only these hidden effects (default: all eight).
    let only: Vec<EffectKind> = arg("--effects", String::new())
        .split(',')
        .filter_map(EffectKind::from_name)
        .collect();
    let mut jobs = Vec::new();
    for kind in EffectKind::ALL {
        if !only.is_empty() && !only.contains(&kind) {
            continue;
        }
        for &enr in &enrs {
            for rho in [0.0, 0.6] {
                for seed in 0..seeds {
                    jobs.push(Job {
                        kind: Some(kind),
                        second: None,
                        enr,
                        rho,
                        seed: 1000 + seed,
                    });
                }
            }
        }
    }
    for seed in 0..fdr {
        jobs.push(Job {
            kind: None,
            second: None,
            enr: 0.0,
            rho: if seed % 2 == 0 { 0.0 } else { 0.6 },
            seed: 5000 + seed,
        });
    }
    let pairs: u64 = arg("--pairs", 10);
    for (a, b) in PAIRS {
        for seed in 0..pairs {
            jobs.push(Job {
                kind: Some(a),
                second: Some(b),
                enr: 6.0,
                rho: if seed % 2 == 0 { 0.0 } else { 0.6 },
                seed: 7000 + seed,
            });
        }
    }
    let bar = ProgressBar::new(jobs.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} ETA {eta} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let results: Mutex<Vec<(usize, Outcome, f64)>> = Mutex::new(Vec::new());
    let next = Mutex::new(0usize);
    // The selection rules alone on the process, machine and spindle effects (no
    // effect-to-noise floor): what each rule recovers on synthetic logs. The CLI's default
    // (the whole library, the floor, the strict rules) is measured by `twin_eval`
    // (docs/twin.md).
    let opts = workflow::Options {
        candidates: acc_ident::EffectKind::PROCESS_AND_MACHINE.to_vec(),
        min_effect_to_noise: 0.0,
        ..workflow::Options::default()
    };
    std::thread::scope(|s| {
        for _ in 0..threads.max(1) {
            s.spawn(|| loop {
                let i = {
                    let Ok(mut g) = next.lock() else { return };
                    let i = *g;
                    *g += 1;
                    i
                };
                let Some(job) = jobs.get(i) else { return };
                let c = case(job.rho);
                let hidden: Vec<Hidden> = job
                    .kind
                    .into_iter()
                    .chain(job.second)
                    .map(|kind| Hidden {
                        kind,
                        value: synth::value_for_enr(&c, kind, job.enr, job.seed),
                    })
                    .collect();
                let achieved = synth::effect_to_noise(&c, &hidden, job.seed);
                if let Ok(o) = synth::evaluate(&c, &hidden, job.seed, &opts) {
                    if let Ok(mut r) = results.lock() {
                        r.push((i, o, achieved));
                    }
                }
                bar.inc(1);
                // indicatif hides itself when stderr is not a terminal: print a line then.
                if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
                    let done = bar.position();
                    if done.checked_rem(20) == Some(0) || done == jobs.len() as u64 {
                        eprintln!(
                            "progress {done}/{} ({:.0} s)",
                            jobs.len(),
                            bar.elapsed().as_secs_f64()
                        );
                    }
                }
            });
        }
    });
    bar.finish();
    let results = results.into_inner().unwrap_or_default();
    let mut md = String::new();
    // (effect, ENR, % exactly right, % interval covers, median gap closed)
    let mut curves: Vec<(EffectKind, f64, f64, f64, f64)> = Vec::new();
    // Confusion matrix at ENR >= 4.
    let cols: Vec<String> = EffectKind::ALL
        .iter()
        .map(|k| k.name().to_string())
        .chain(["none".into(), "ambiguous".into(), "2+ named".into()])
        .collect();
    let mut conf: BTreeMap<(usize, String), usize> = BTreeMap::new();
    let mut rows_total: BTreeMap<usize, usize> = BTreeMap::new();
    for (i, o, achieved) in &results {
        let j = &jobs[*i];
        let Some(kind) = j.kind else { continue };
        if *achieved < 4.0 || j.second.is_some() {
            continue;
        }
        let r = kind as usize;
        let col = if !o.ambiguous.is_empty() {
            "ambiguous".to_string()
        } else if o.named.len() > 1 {
            "2+ named".to_string()
        } else if let Some(k) = o.named.first() {
            k.name().to_string()
        } else {
            "none".to_string()
        };
        *conf.entry((r, col)).or_default() += 1;
        *rows_total.entry(r).or_default() += 1;
    }
    out!(
        md,
        "\nConfusion matrix at achieved ENR >= 4 (rows: hidden effect, % of runs):\n"
    );
    out!(md, "| hidden \\ named | {} |", cols.join(" | "));
    out!(md, "| --- |{}", " ---: |".repeat(cols.len()));
    for kind in EffectKind::ALL {
        let r = kind as usize;
        let tot = rows_total.get(&r).copied().unwrap_or(0).max(1) as f64;
        let cells: Vec<String> = cols
            .iter()
            .map(|c| {
                let v = conf.get(&(r, c.clone())).copied().unwrap_or(0) as f64;
                if v == 0.0 {
                    "·".into()
                } else {
                    format!("{:.0}", 100.0 * v / tot)
                }
            })
            .collect();
        out!(md, "| {} | {} |", kind.name(), cells.join(" | "));
    }
    out!(md, "\nRecovery vs effect-to-noise ratio (% exactly right / % interval covers truth / median sealed-part gap closed; `max x` when the effect's bound caps the ENR at x):\n");
    let hdr: Vec<String> = enrs.iter().map(|e| format!("ENR {e}")).collect();
    out!(md, "| effect | {} |", hdr.join(" | "));
    out!(md, "| --- |{}", " --- |".repeat(enrs.len()));
    for kind in EffectKind::ALL {
        let cells: Vec<String> = enrs
            .iter()
            .map(|&enr| {
                let sel: Vec<&(usize, Outcome, f64)> = results
                    .iter()
                    .filter(|(i, _, _)| {
                        jobs[*i].kind == Some(kind)
                            && jobs[*i].second.is_none()
                            && jobs[*i].enr == enr
                    })
                    .collect();
                let os: Vec<&Outcome> = sel.iter().map(|(_, o, _)| o).collect();
                let min_achieved = sel.iter().map(|r| r.2).fold(f64::INFINITY, f64::min);
                let n = os.len().max(1) as f64;
                let exact = os.iter().filter(|o| o.exact).count() as f64;
                let cov: Vec<bool> = os.iter().filter_map(|o| o.covered[0]).collect();
                let covp =
                    100.0 * cov.iter().filter(|c| **c).count() as f64 / cov.len().max(1) as f64;
                let mut gap: Vec<f64> = os.iter().map(|o| o.gap_closed).collect();
                gap.sort_by(f64::total_cmp);
                let med = gap.get(gap.len() / 2).copied().unwrap_or(f64::NAN);
                let cap = if min_achieved < 0.9 * enr {
                    format!(" (max {min_achieved:.1})")
                } else {
                    String::new()
                };
                curves.push((kind, enr, 100.0 * exact / n, covp, med));
                format!("{:.0} / {:.0} / {:.2}{cap}", 100.0 * exact / n, covp, med)
            })
            .collect();
        out!(md, "| {} | {} |", kind.name(), cells.join(" | "));
    }
    out!(
        md,
        "\nTwo hidden effects (each sized alone to ENR 6; % of seeds):\n"
    );
    out!(md, "| pair | both named | ambiguous, right pair | other |");
    out!(md, "| --- | ---: | ---: | ---: |");
    for (a, b) in PAIRS {
        let os: Vec<&Outcome> = results
            .iter()
            .filter(|(i, _, _)| jobs[*i].kind == Some(a) && jobs[*i].second == Some(b))
            .map(|(_, o, _)| o)
            .collect();
        let n = os.len().max(1) as f64;
        let extra = |o: &Outcome| o.named.iter().any(|k| *k != a && *k != b);
        let both = os
            .iter()
            .filter(|o| o.named.contains(&a) && o.named.contains(&b) && !extra(o))
            .count();
        let amb = os
            .iter()
            .filter(|o| {
                !(extra(o) || (o.named.contains(&a) && o.named.contains(&b)))
                    && o.ambiguous
                        .iter()
                        .any(|&(x, y)| (x == a && y == b) || (x == b && y == a))
            })
            .count();
        out!(
            md,
            "| {} + {} | {:.0} | {:.0} | {:.0} |",
            a.name(),
            b.name(),
            100.0 * both as f64 / n,
            100.0 * amb as f64 / n,
            100.0 * (os.len() - both - amb) as f64 / n
        );
    }
    let nulls: Vec<&Outcome> = results
        .iter()
        .filter(|(i, _, _)| jobs[*i].kind.is_none())
        .map(|(_, o, _)| o)
        .collect();
    let fp = nulls
        .iter()
        .filter(|o| !o.named.is_empty() || !o.ambiguous.is_empty())
        .count();
    out!(
        md,
        "\nNo hidden effect: an effect named in {fp} of {} seeds ({:.1} %), unexplained in {}.",
        nulls.len(),
        100.0 * fp as f64 / nulls.len().max(1) as f64,
        nulls.iter().filter(|o| o.unexplained).count()
    );
    let dir = std::path::PathBuf::from(arg("--out", "out/sweep".to_string()));
    if let Err(e) = write_outputs(&dir, &md, &curves) {
        eprintln!("error: writing {}: {e}", dir.display());
        std::process::exit(2);
    }
    println!("\nwrote {}/sweep.md and recovery.svg/.png", dir.display());
}

/// `sweep.md` and the recovery-versus-size curves (x: log₂ ENR).
fn write_outputs(
    dir: &std::path::Path,
    md: &str,
    curves: &[(EffectKind, f64, f64, f64, f64)],
) -> Result<(), Box<dyn std::error::Error>> {
    use acc_plot::{Figure, HLine, Panel, Series};
    std::fs::create_dir_all(dir)?;
    std::fs::write(dir.join("sweep.md"), md)?;
    let series = |pick: fn(&(EffectKind, f64, f64, f64, f64)) -> f64| -> Vec<Series> {
        EffectKind::ALL
            .iter()
            .map(|k| {
                let pts = curves
                    .iter()
                    .filter(|c| c.0 == *k && c.1 > 0.0)
                    .map(|c| (c.1.log2(), pick(c)))
                    .filter(|p| p.1.is_finite())
                    .collect();
                Series::line(k.name(), pts)
            })
            .collect()
    };
    let panel = |y_label: &str,
                 pick: fn(&(EffectKind, f64, f64, f64, f64)) -> f64,
                 target: HLine,
                 top: f64| Panel {
        y_label: y_label.into(),
        series: series(pick),
        hlines: vec![target],
        y_range: Some((0.0, top)),
        ..Panel::default()
    };
    let fig = Figure {
        title: "Hidden-effect recovery against effect size".into(),
        x_label: "effect-to-noise ratio, log₂ (−2 = 0.25, 0 = 1, 2 = 4, 3 = 8)".into(),
        panels: vec![
            panel(
                "exactly right [%]",
                |c| c.2,
                HLine::new("target 90 % at ENR ≥ 4", 90.0),
                105.0,
            ),
            panel(
                "interval covers truth [%]",
                |c| c.3,
                HLine::new("95 %", 95.0),
                105.0,
            ),
            panel(
                "sealed gap closed (median)",
                |c| c.4,
                HLine::new("target 0.8", 0.8),
                1.1,
            ),
        ],
        panel_height_px: 300,
        ..Figure::default()
    };
    acc_plot::time_series(&fig, dir.join("recovery.svg"))?;
    Ok(())
}
