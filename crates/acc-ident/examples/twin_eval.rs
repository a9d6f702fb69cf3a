//! The honest twin's evaluation (issue 13): logs made by `acc sim`'s production loop
//! (`acc_sim::run`, the same `ControlLoop` as `acc run`) on the shipped workpieces, with
//! hidden effects in the simulated machine — in the library, out of it, none — analysed by
//! the discrepancy workflow on both channels; confusion matrix per channel, false
//! discovery, recovery, interval coverage, out-of-library naming. Cases run in parallel on
//! `--threads` std threads.
//!
//! cargo run --release -p acc-ident --example twin_eval -- --null-seeds 200 \
//!     --lib-seeds 1 --oob-seeds 1 --threads 2 --out out/twin --update-doc docs/twin.md
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use acc_ident::model::Channel;
use acc_ident::twin::{run_case, Hidden, Verdict};

const WORKPIECES: [&str; 5] = [
    "steps_1_2_3.toml",
    "steps_2_3_4.toml",
    "ramp_2_4.toml",
    "interrupted.toml",
    "hard_inclusion.toml",
];

/// In-library effects at two amplitudes.
fn library() -> Vec<Hidden> {
    vec![
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
        Hidden::LogGainDrift(0.02),
        Hidden::LogGainDrift(0.06),
        Hidden::LogDelay(1),
        Hidden::LogDelay(3),
        Hidden::DepthExponent(0.85),
        Hidden::DepthExponent(1.15),
        Hidden::KsStep(0.8),
        Hidden::KsStep(1.3),
        Hidden::SecondOrderDrive(0.05),
        Hidden::SecondOrderDrive(0.15),
    ]
}

/// Effects outside the library, at two amplitudes (the tooth model at one).
fn out_of_library() -> Vec<Hidden> {
    vec![
        Hidden::ToothModel,
        Hidden::DepthScale(0.9),
        Hidden::DepthScale(1.1),
        Hidden::PositionOffset(2.0),
        Hidden::PositionOffset(5.0),
        Hidden::HardBands(1.15),
        Hidden::HardBands(1.3),
        Hidden::EntryChamfer(3.0),
        Hidden::EntryChamfer(8.0),
        Hidden::KsTimeDrift(0.05),
        Hidden::KsTimeDrift(0.15),
        Hidden::LogSpikes(0.2),
        Hidden::LogSpikes(0.5),
    ]
}

fn outcome(v: &Verdict) -> String {
    if !v.named.is_empty() {
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
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |k: &str| {
        args.iter()
            .position(|a| a == k)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let num = |k: &str, d: u64| get(k).and_then(|s| s.parse().ok()).unwrap_or(d);
    let null_seeds = num("--null-seeds", 10);
    let lib_seeds = num("--lib-seeds", 1);
    let oob_seeds = num("--oob-seeds", 1);
    let threads = num("--threads", 2).max(1) as usize;
    let max_time = num("--max-time", 60) as f64;
    // --wp-limit N: the first N shipped workpieces only (a quick look).
    let nwp = num("--wp-limit", 5).clamp(1, 5) as usize;
    // --channels power|force (default both); --skip LABEL-PREFIX[,…]: leave effects out.
    let channels: Vec<Channel> = match get("--channels").as_deref() {
        Some("power") => vec![Channel::Power],
        Some("force") => vec![Channel::Force],
        _ => vec![Channel::Power, Channel::Force],
    };
    let skip: Vec<String> = get("--skip")
        .map(|s| s.split(',').map(str::to_string).collect())
        .unwrap_or_default();
    let out = std::path::PathBuf::from(get("--out").unwrap_or_else(|| "out/twin".into()));
    let doc = get("--update-doc");
    std::fs::create_dir_all(&out).expect("out dir");
    let dir = acc_sim::run::configs_dir();
    let mut base =
        acc_sim::Scenario::load(dir.join("scenarios/paper_case3.toml")).expect("scenario");
    base.max_time_s = max_time;
    let wps: Vec<acc_sim::Workpiece> = WORKPIECES
        .iter()
        .map(|w| acc_sim::Workpiece::load(dir.join("workpieces").join(w)).expect("wp"))
        .collect();
    let estimated = acc_ident::twin::estimator_of(&base).is_some();
    // The cases: (channel, hidden, workpiece, seed). Null seeds are spread over the
    // workpieces (null_seeds per channel in all).
    let mut cases: Vec<(Channel, Hidden, usize, u64)> = Vec::new();
    for &ch in &channels {
        for k in 0..null_seeds {
            cases.push((ch, Hidden::Null, (k as usize) % nwp, 5000 + k));
        }
        for (set, seeds) in [(library(), lib_seeds), (out_of_library(), oob_seeds)] {
            for h in set {
                if !h.acts_on(ch, estimated) || skip.iter().any(|p| h.label().starts_with(p)) {
                    continue;
                }
                for wi in 0..nwp {
                    for s in 0..seeds {
                        cases.push((ch, h, wi, 1000 + 37 * s + 7 * wi as u64));
                    }
                }
            }
        }
    }
    let t0 = std::time::Instant::now();
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<Verdict>>> = Mutex::new(vec![None; cases.len()]);
    std::thread::scope(|sc| {
        for _ in 0..threads {
            sc.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(&(ch, h, wi, seed)) = cases.get(i) else {
                    break;
                };
                let mut s = base.clone();
                s.workpiece = wps[wi].clone();
                let v = run_case(&s, h, ch, seed);
                match &v {
                    // The progress line ends with the case's CSV row (`case,…`), so a run
                    // stopped early can still be summarised.
                    Ok(v) => eprintln!(
                        "[{i}/{}] {:.0} s {ch:?} {} {} seed {seed}: {} | case,{ch:?},{},{},{seed},{},{},{},{},{:?}",
                        cases.len(),
                        t0.elapsed().as_secs_f64(),
                        h.label(),
                        WORKPIECES[wi],
                        outcome(v),
                        h.label(),
                        WORKPIECES[wi],
                        outcome(v),
                        v.ambiguous,
                        v.unexplained,
                        v.withheld.join("+"),
                        v.covered
                    ),
                    Err(e) => eprintln!("{ch:?} {} {} {seed}: {e}", h.label(), WORKPIECES[wi]),
                }
                if let Ok(mut r) = results.lock() {
                    r[i] = v.ok();
                }
            });
        }
    });
    let results = results.into_inner().expect("results");
    let elapsed = t0.elapsed().as_secs_f64();
    let mut md = String::new();
    let mut csv = String::from(
        "channel,hidden,workpiece,seed,outcome,ambiguous,unexplained,withheld,covered\n",
    );
    for &ch in &channels {
        let mut conf: BTreeMap<(u8, String), BTreeMap<String, usize>> = BTreeMap::new();
        let (mut null_n, mut null_named, mut null_unexpl) = (0, 0, 0);
        let (mut lib_n, mut lib_ok, mut cov_n, mut cov_ok) = (0, 0, 0, 0);
        let (mut oob_n, mut oob_named, mut oob_amb, mut oob_unex) = (0, 0, 0, 0);
        for ((c, h, wi, seed), v) in cases.iter().zip(&results) {
            if *c != ch {
                continue;
            }
            let Some(v) = v else { continue };
            let o = outcome(v);
            let _ = writeln!(
                csv,
                "{ch:?},{},{},{seed},{o},{},{},{},{:?}",
                h.label(),
                WORKPIECES[*wi],
                v.ambiguous,
                v.unexplained,
                v.withheld.join("+"),
                v.covered
            );
            let group = match (h, h.library()) {
                (Hidden::Null, _) => 0,
                (_, Some(_)) => 1,
                _ => 2,
            };
            let cell = if group == 2 && !v.named.is_empty() {
                format!("named {o}")
            } else {
                o.clone()
            };
            *conf
                .entry((group, h.label()))
                .or_default()
                .entry(cell)
                .or_default() += 1;
            match group {
                0 => {
                    null_n += 1;
                    null_named += usize::from(!v.named.is_empty());
                    null_unexpl += usize::from(v.unexplained);
                }
                1 => {
                    lib_n += 1;
                    lib_ok += usize::from(Some(v.named.clone()) == h.library().map(|k| vec![k]));
                    if let Some(c) = v.covered {
                        cov_n += 1;
                        cov_ok += usize::from(c);
                    }
                }
                _ => {
                    oob_n += 1;
                    if !v.named.is_empty() {
                        oob_named += 1;
                    } else if v.ambiguous {
                        oob_amb += 1;
                    } else if v.unexplained {
                        oob_unex += 1;
                    }
                }
            }
        }
        let pct = |a: usize, b: usize| {
            if b == 0 {
                f64::NAN
            } else {
                100.0 * a as f64 / b as f64
            }
        };
        let name = if ch == Channel::Power {
            "power"
        } else {
            "force"
        };
        let _ = writeln!(md, "### Channel `{name}`\n");
        let _ = writeln!(md, "- false discovery (an effect named on a null log): **{null_named} of {null_n}** ({:.1} %); \"unexplained\" on null logs: {null_unexpl} of {null_n} ({:.1} %)", pct(null_named, null_n), pct(null_unexpl, null_n));
        let _ = writeln!(md, "- recovery (exactly the hidden in-library effect named): **{lib_ok} of {lib_n}** ({:.1} %); interval covers the truth: {cov_ok} of {cov_n} ({:.1} %)", pct(lib_ok, lib_n), pct(cov_ok, cov_n));
        let _ = writeln!(md, "- out-of-library effects named as a library effect: **{oob_named} of {oob_n}** ({:.1} %); ambiguous {oob_amb}, unexplained {oob_unex}, nothing {}\n", pct(oob_named, oob_n), oob_n - oob_named - oob_amb - oob_unex);
        let _ = writeln!(
            md,
            "| group | hidden \\ verdict | verdicts (count) |\n| --- | --- | --- |"
        );
        for ((g, h), m) in &conf {
            let cells: Vec<String> = m.iter().map(|(o, c)| format!("{o}: {c}")).collect();
            let gname = ["null", "in library", "out of library"][*g as usize];
            let _ = writeln!(md, "| {gname} | {h} | {} |", cells.join(", "));
        }
        let _ = writeln!(md);
    }
    let _ = writeln!(
        md,
        "{null_seeds} null seeds per channel (spread over the 5 shipped workpieces), {lib_seeds} seed(s) × 5 workpieces per in-library cell, {oob_seeds} seed(s) × 5 workpieces per out-of-library cell; {} cases, {elapsed:.0} s on {threads} threads (release build).",
        cases.len()
    );
    std::fs::write(out.join("twin.md"), &md).expect("write");
    std::fs::write(out.join("cases.csv"), &csv).expect("write");
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
