//! The honest twin's evaluation (issue 13): logs made by `acc sim`'s production loop on the
//! shipped workpieces, with hidden effects in the simulated machine (in the library, out of
//! it, none), analysed by the discrepancy workflow on both channels; confusion matrix per
//! channel, false discovery, recovery and interval coverage.
//!
//! cargo run --release -p acc-ident --example twin_eval -- --seeds 4 --out out/twin \
//!     [--update-doc docs/twin.md]
use std::collections::BTreeMap;
use std::fmt::Write as _;

use acc_ident::model::Channel;
use acc_ident::twin::{run_case, Hidden};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |k: &str| {
        args.iter()
            .position(|a| a == k)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let seeds: u64 = get("--seeds").and_then(|s| s.parse().ok()).unwrap_or(2);
    let out = std::path::PathBuf::from(get("--out").unwrap_or_else(|| "out/twin".into()));
    let doc = get("--update-doc");
    std::fs::create_dir_all(&out).expect("out dir");
    let dir = acc_sim::run::configs_dir();
    let mut base =
        acc_sim::Scenario::load(dir.join("scenarios/paper_case3.toml")).expect("scenario");
    base.max_time_s = 60.0;
    let all_wp =
        "steps_1_2_3.toml,steps_2_3_4.toml,ramp_2_4.toml,interrupted.toml,hard_inclusion.toml"
            .to_string();
    let wp_arg = get("--workpieces").unwrap_or(all_wp);
    let workpieces: Vec<&str> = wp_arg.split(',').collect();
    let single = args.iter().any(|a| a == "--one-amplitude");
    let hidden: Vec<Hidden> = vec![
        Hidden::Null,
        Hidden::ToolWear(0.03),
        Hidden::ToolWear(0.08),
        Hidden::FeedDriveLag(0.03),
        Hidden::FeedDriveLag(0.08),
        Hidden::OverrideDeadTime(0.05),
        Hidden::OverrideDeadTime(0.12),
        Hidden::CopperLoss(0.1),
        Hidden::CopperLoss(0.3),
        Hidden::NoloadDrift(40.0),
        Hidden::NoloadDrift(120.0),
        Hidden::SensorLowpass(0.1),
        Hidden::SensorLowpass(0.3),
        Hidden::Runout(0.05),
        Hidden::Runout(0.15),
        Hidden::DepthExponent(0.85),
        Hidden::DepthExponent(1.15),
        Hidden::KsStep(0.8),
        Hidden::KsStep(1.3),
        Hidden::ToothModel,
    ];
    // --one-amplitude: the larger amplitude of each effect only.
    let hidden: Vec<Hidden> = if single {
        hidden
            .iter()
            .enumerate()
            .filter(|(i, h)| matches!(h, Hidden::Null | Hidden::ToothModel) || i % 2 == 0)
            .map(|(_, h)| *h)
            .collect()
    } else {
        hidden
    };
    let t0 = std::time::Instant::now();
    let mut md = String::new();
    let mut rows_csv =
        String::from("channel,hidden,workpiece,seed,named,ambiguous,unexplained,covered\n");
    for ch in [Channel::Power, Channel::Force] {
        // hidden label → outcome label → count
        let mut conf: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
        let (mut null_n, mut null_named, mut null_unexpl) = (0, 0, 0);
        let (mut lib_n, mut lib_ok, mut cov_n, mut cov_ok) = (0, 0, 0, 0);
        let (mut out_n, mut out_named) = (0, 0);
        for &h in &hidden {
            if !h.acts_on(ch, acc_ident::twin::estimator_of(&base).is_some()) {
                continue;
            }
            for (wi, wp) in workpieces.iter().enumerate() {
                let mut sc = base.clone();
                sc.workpiece =
                    acc_sim::Workpiece::load(dir.join("workpieces").join(wp)).expect("wp");
                for s in 0..seeds {
                    let seed = 1000 + 37 * s + 7 * wi as u64;
                    let v = match run_case(&sc, h, ch, seed) {
                        Ok(v) => v,
                        Err(e) => {
                            eprintln!("{ch:?} {} {wp} {seed}: {e}", h.label());
                            continue;
                        }
                    };
                    let outcome = if !v.named.is_empty() {
                        v.named
                            .iter()
                            .map(|k| k.name())
                            .collect::<Vec<_>>()
                            .join("+")
                    } else if v.ambiguous {
                        "ambiguous".into()
                    } else if v.unexplained {
                        "unexplained".into()
                    } else {
                        "none".into()
                    };
                    eprintln!("  {ch:?} {} {wp} seed {seed}: {outcome}", h.label());
                    let _ = writeln!(
                        rows_csv,
                        "{ch:?},{},{wp},{seed},{},{},{},{:?}",
                        h.label(),
                        outcome,
                        v.ambiguous,
                        v.unexplained,
                        v.covered
                    );
                    *conf
                        .entry(h.label())
                        .or_default()
                        .entry(outcome.clone())
                        .or_default() += 1;
                    match h {
                        Hidden::Null => {
                            null_n += 1;
                            null_named += usize::from(!v.named.is_empty());
                            null_unexpl += usize::from(v.unexplained);
                        }
                        _ => match h.library() {
                            Some(k) => {
                                lib_n += 1;
                                lib_ok += usize::from(v.named == vec![k]);
                                if let Some(c) = v.covered {
                                    cov_n += 1;
                                    cov_ok += usize::from(c);
                                }
                            }
                            None => {
                                out_n += 1;
                                out_named += usize::from(!v.named.is_empty());
                            }
                        },
                    }
                }
            }
            eprintln!(
                "{ch:?} {} done ({:.0} s)",
                h.label(),
                t0.elapsed().as_secs_f64()
            );
        }
        let pct = |a: usize, b: usize| {
            if b == 0 {
                f64::NAN
            } else {
                100.0 * a as f64 / b as f64
            }
        };
        let _ = writeln!(
            md,
            "### Channel `{}`\n",
            if ch == Channel::Power {
                "power"
            } else {
                "force"
            }
        );
        let _ = writeln!(md, "- false discovery (an effect named on a null log): **{null_named} of {null_n}** ({:.1} %); \"unexplained\" on null logs: {null_unexpl} of {null_n} ({:.1} %)", pct(null_named, null_n), pct(null_unexpl, null_n));
        let _ = writeln!(md, "- recovery (exactly the hidden in-library effect named): **{lib_ok} of {lib_n}** ({:.1} %); interval covers the truth: {cov_ok} of {cov_n} ({:.1} %)", pct(lib_ok, lib_n), pct(cov_ok, cov_n));
        let _ = writeln!(md, "- out-of-library effects named as a library effect: **{out_named} of {out_n}** ({:.1} %)\n", pct(out_named, out_n));
        let _ = writeln!(
            md,
            "| hidden \\ verdict | verdicts (count) |\n| --- | --- |"
        );
        for (h, m) in &conf {
            let cells: Vec<String> = m.iter().map(|(o, c)| format!("{o}: {c}")).collect();
            let _ = writeln!(md, "| {h} | {} |", cells.join(", "));
        }
        let _ = writeln!(md);
    }
    let _ = writeln!(
        md,
        "{} seeds × {} workpieces per cell; {:.0} s.",
        seeds,
        workpieces.len(),
        t0.elapsed().as_secs_f64()
    );
    std::fs::write(out.join("twin.md"), &md).expect("write");
    std::fs::write(out.join("cases.csv"), &rows_csv).expect("write");
    println!("{md}");
    if let Some(doc) = doc {
        let text = std::fs::read_to_string(&doc).unwrap_or_default();
        let (a, b) = ("<!-- twin-eval:begin -->", "<!-- twin-eval:end -->");
        let new = match (text.find(a), text.find(b)) {
            (Some(i), Some(j)) if j > i => format!("{}{a}\n{md}{}", &text[..i], &text[j..]),
            _ => format!("{text}\n{a}\n{md}{b}\n"),
        };
        std::fs::write(&doc, new).expect("write doc");
    }
}
