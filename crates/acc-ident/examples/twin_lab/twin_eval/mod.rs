//! The honest twin's evaluation: logs made by `acc sim`'s production loop
//! (`acc_sim::run`, the same `ControlLoop` as `acc run`) on the shipped workpieces, with
//! hidden effects in the simulated machine — in the library, out of it, none — analysed by
//! the discrepancy workflow on both channels; per channel the confusion matrix (hidden
//! effect × verdict), false discovery, recovery (overall and at effect/noise ≥ 4),
//! interval coverage, out-of-library naming. Cases run in parallel on `--threads` std
//! threads; each finished case's row is appended to `<out>/cases.csv` at once, and
//! `--resume FILE` (a `cases.csv` of a run stopped early) skips the cases already in it;
//! `--report-only` with it writes the figures of those rows without running the rest.
//!
//! cargo run --release -p acc-ident --example twin_lab -- twin_eval --null-seeds 200 \
//!     --lib-seeds 1 --oob-seeds 1 --threads 2 --out out/twin --update-doc docs/twin-evaluation.md
//!
//! Other options: `--channels power|force`, `--skip LABEL-PREFIX[,…]`,
//! `--only LABEL-PREFIX[,…]`, `--wp-limit N`, `--max-time S`; `--replay logged` analyses
//! each log on its own depths (no workpiece: not an exact replay, as on a real machine),
//! `--rules off` without the withholding rules (what they change).
//!
//! `--path board` ([`board`]): the logs are `acc run`'s, controlling `acc board-sim` over
//! a pty (one closed loop at a time, kept under `<out>/board/`), and the verdicts `acc
//! discrepancy`'s; `--acc PATH` names the binary (default `target/release/acc`: build it
//! with `cargo build --release -p acc-cli`). With `--update-doc` the block between
//! `<!-- twin-eval-board:begin -->` and `<!-- twin-eval-board:end -->` is replaced.
//!
//! cargo run --release -p acc-ident --example twin_lab -- twin_eval --path board --null-seeds 20 \
//!     --wp-limit 2 --oob-seeds 1 --out out/twin-board --update-doc docs/twin-evaluation.md

mod board;

use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::io::Write as _;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use acc_ident::model::Channel;
use acc_ident::twin::{self, run_case_with, CaseAnalysis, Hidden, Verdict};
use acc_ident::EffectKind;

const WORKPIECES: [&str; 5] = [
    "steps_1_2_3.toml",
    "steps_2_3_4.toml",
    "ramp_2_4.toml",
    "interrupted.toml",
    "hard_inclusion.toml",
];

/// The effect-to-noise ratio above which recovery is required (docs/twin.md).
const ENR_MIN: f64 = 4.0;

const CSV_HEADER: &str =
    "channel,hidden,workpiece,seed,enr,outcome,ambiguous,unexplained,withheld,covered,enr_calibrated";

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
        Hidden::LogZeroShift(0.02),
        Hidden::LogZeroShift(0.05),
        Hidden::LogInterference(0.01),
        Hidden::LogInterference(0.03),
        Hidden::LogClip(0.9),
        Hidden::LogClip(0.75),
        Hidden::LogQuantize(0.02),
        Hidden::LogQuantize(0.05),
        Hidden::LogStale(0.05),
        Hidden::LogStale(0.2),
        Hidden::DepthThreshold(0.1),
        Hidden::DepthThreshold(0.3),
        Hidden::LogZeroDrift(0.02),
        Hidden::LogZeroDrift(0.05),
        Hidden::NcOverrideCap(120),
        Hidden::NcOverrideCap(100),
    ]
}

/// Two library effects at once (both should be named), at two amplitudes of the wear.
fn pairs() -> Vec<Hidden> {
    vec![
        Hidden::WearAndNoloadDrift(0.03),
        Hidden::WearAndNoloadDrift(0.08),
        Hidden::WearAndFeedDriveLag(0.03),
        Hidden::WearAndFeedDriveLag(0.08),
    ]
}

/// What one finished case said: the fields of its `cases.csv` row.
#[derive(Debug, Clone)]
struct Row {
    named: Vec<EffectKind>,
    ambiguous: bool,
    unexplained: bool,
    withheld: String,
    covered: Option<bool>,
    enr: f64,
    /// Effect-to-noise ratio after calibration (`None`: a resumed row of an older run,
    /// computed before the tables are made).
    enr_cal: Option<f64>,
}

impl Row {
    fn of(v: &Verdict) -> Row {
        Row {
            named: v.named.clone(),
            ambiguous: v.ambiguous,
            unexplained: v.unexplained,
            withheld: v.withheld.join("+"),
            covered: v.covered,
            enr: v.enr,
            enr_cal: Some(v.enr_calibrated),
        }
    }

    /// "A", "A+B", "ambiguous", "unexplained" or "none".
    fn outcome(&self) -> String {
        if !self.named.is_empty() {
            self.named
                .iter()
                .map(|k| k.name())
                .collect::<Vec<_>>()
                .join("+")
        } else if self.ambiguous {
            "ambiguous".into()
        } else if self.unexplained {
            "unexplained".into()
        } else {
            "none".into()
        }
    }

    /// The confusion matrix's column: the effect named alone, "several", "ambiguous",
    /// "unexplained" or "nothing".
    fn column(&self) -> String {
        match self.named.len() {
            1 => self.named[0].name().into(),
            n if n > 1 => "several".into(),
            _ if self.ambiguous => "ambiguous".into(),
            _ if self.unexplained => "unexplained".into(),
            _ => "nothing".into(),
        }
    }
}

type Key = (String, String, String, u64);

fn csv_row(key: &Key, r: &Row) -> String {
    let covered = match r.covered {
        Some(true) => "true",
        Some(false) => "false",
        None => "",
    };
    format!(
        "{},{},{},{},{:.3},{},{},{},{},{covered},{}",
        key.0,
        key.1,
        key.2,
        key.3,
        r.enr,
        r.outcome(),
        r.ambiguous,
        r.unexplained,
        r.withheld,
        r.enr_cal.map(|e| format!("{e:.3}")).unwrap_or_default()
    )
}

fn parse_row(line: &str) -> Option<(Key, Row)> {
    let f: Vec<&str> = line.split(',').collect();
    if !(10..=11).contains(&f.len()) || f[0] == "channel" {
        return None;
    }
    let named = match f[5] {
        "ambiguous" | "unexplained" | "none" => Vec::new(),
        o => o
            .split('+')
            .map(EffectKind::from_name)
            .collect::<Option<Vec<_>>>()?,
    };
    let key = (f[0].into(), f[1].into(), f[2].into(), f[3].parse().ok()?);
    Some((
        key,
        Row {
            named,
            ambiguous: f[6].parse().ok()?,
            unexplained: f[7].parse().ok()?,
            withheld: f[8].into(),
            covered: match f[9] {
                "true" => Some(true),
                "false" => Some(false),
                _ => None,
            },
            enr: f[4].parse().ok()?,
            enr_cal: f.get(10).and_then(|e| e.parse().ok()),
        },
    ))
}

/// Run `f(i)` for every index of `todo` on `threads` std threads (work shared by a counter).
fn parallel(todo: &[usize], threads: usize, f: impl Fn(usize) + Sync) {
    let next = AtomicUsize::new(0);
    std::thread::scope(|sc| {
        for _ in 0..threads {
            sc.spawn(|| {
                while let Some(&i) = todo.get(next.fetch_add(1, Ordering::Relaxed)) {
                    f(i);
                }
            });
        }
    });
}

/// `cases.csv`: the header and one line per finished case.
fn csv_text<'a>(rows: impl Iterator<Item = (Key, &'a Row)>) -> String {
    let mut csv = String::from(CSV_HEADER);
    csv.push('\n');
    for (k, r) in rows {
        csv.push_str(&csv_row(&k, r));
        csv.push('\n');
    }
    csv
}

fn pct(a: usize, b: usize) -> f64 {
    if b == 0 {
        f64::NAN
    } else {
        100.0 * a as f64 / b as f64
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// The summary and confusion matrix of one channel.
fn channel_md(name: &str, rows: &[(Hidden, &Row)]) -> String {
    let mut md = String::new();
    let group = |h: &Hidden| match (h, h.library(), h.library_pair()) {
        (Hidden::Null, _, _) => 0usize,
        (_, Some(_), _) => 1,
        (_, _, Some(_)) => 3,
        _ => 2,
    };
    // A pair is recovered when both of its effects, and nothing else, are named.
    let both = |h: &Hidden, r: &Row| {
        h.library_pair()
            .is_some_and(|p| r.named.len() == 2 && p.iter().all(|k| r.named.contains(k)))
    };
    let exact = |h: &Hidden, r: &Row| h.library().is_some_and(|k| r.named == [k]);
    let count = |f: &dyn Fn(&Hidden, &Row) -> bool| rows.iter().filter(|(h, r)| f(h, r)).count();
    let null_n = count(&|h, _| group(h) == 0);
    let null_named = count(&|h, r| group(h) == 0 && !r.named.is_empty());
    let null_unex = count(&|h, r| group(h) == 0 && r.named.is_empty() && r.unexplained);
    let lib_n = count(&|h, _| group(h) == 1);
    let lib_ok = count(&|h, r| group(h) == 1 && exact(h, r));
    let lib4_n = count(&|h, r| group(h) == 1 && r.enr >= ENR_MIN);
    let lib4_ok = count(&|h, r| group(h) == 1 && r.enr >= ENR_MIN && exact(h, r));
    let cov_n = count(&|h, r| group(h) == 1 && r.covered.is_some());
    let cov_ok = count(&|h, r| group(h) == 1 && r.covered == Some(true));
    let cov4_n = count(&|h, r| group(h) == 1 && r.enr >= ENR_MIN && r.covered.is_some());
    let cov4_ok = count(&|h, r| group(h) == 1 && r.enr >= ENR_MIN && r.covered == Some(true));
    let cal4 = |r: &Row| r.enr_cal.is_some_and(|e| e >= ENR_MIN);
    let libc_n = count(&|h, r| group(h) == 1 && cal4(r));
    let libc_ok = count(&|h, r| group(h) == 1 && cal4(r) && exact(h, r));
    let covc_n = count(&|h, r| group(h) == 1 && cal4(r) && r.covered.is_some());
    let covc_ok = count(&|h, r| group(h) == 1 && cal4(r) && r.covered == Some(true));
    let oobc_n = count(&|h, r| group(h) == 2 && cal4(r));
    let oobc_named = count(&|h, r| group(h) == 2 && cal4(r) && !r.named.is_empty());
    let oob_n = count(&|h, _| group(h) == 2);
    let oob_named = count(&|h, r| group(h) == 2 && !r.named.is_empty());
    let oob_col = |c: &str| count(&|h, r| group(h) == 2 && r.column() == c);
    let oob4_n = count(&|h, r| group(h) == 2 && r.enr >= ENR_MIN);
    let oob4_named = count(&|h, r| group(h) == 2 && r.enr >= ENR_MIN && !r.named.is_empty());
    let pair_n = count(&|h, _| group(h) == 3);
    let pair_ok = count(&|h, r| group(h) == 3 && both(h, r));
    let pair_one = count(&|h, r| {
        group(h) == 3
            && !both(h, r)
            && h.library_pair()
                .is_some_and(|p| !r.named.is_empty() && r.named.iter().all(|k| p.contains(k)))
    });
    let _ = writeln!(md, "### Channel `{name}`\n");
    let _ = writeln!(
        md,
        "- false discovery (an effect named on a null log): **{null_named} of {null_n}** ({:.1} %); \"unexplained\" on null logs: {null_unex} of {null_n} ({:.1} %)",
        pct(null_named, null_n),
        pct(null_unex, null_n)
    );
    let _ = writeln!(
        md,
        "- recovery (exactly the hidden in-library effect named): **{lib_ok} of {lib_n}** ({:.1} %) overall; at effect/noise ≥ {ENR_MIN}: **{lib4_ok} of {lib4_n}** ({:.1} %)",
        pct(lib_ok, lib_n),
        pct(lib4_ok, lib4_n)
    );
    let _ = writeln!(
        md,
        "- interval covers the true amplitude (cases naming the hidden effect): **{cov_ok} of {cov_n}** ({:.1} %); at effect/noise ≥ {ENR_MIN}: {cov4_ok} of {cov4_n} ({:.1} %)",
        pct(cov_ok, cov_n),
        pct(cov4_ok, cov4_n)
    );
    let _ = writeln!(
        md,
        "- out-of-library effects named as a library effect: **{oob_named} of {oob_n}** ({:.1} %); ambiguous {}, unexplained {}, nothing {}; at effect/noise ≥ {ENR_MIN}: {oob4_named} of {oob4_n} ({:.1} %)",
        pct(oob_named, oob_n),
        oob_col("ambiguous"),
        oob_col("unexplained"),
        oob_col("nothing"),
        pct(oob4_named, oob4_n)
    );
    let _ = writeln!(
        md,
        "- at effect/noise after calibration ≥ {ENR_MIN} (the part of the effect a refit of `Ks` and the no-load offset cannot absorb): recovery **{libc_ok} of {libc_n}** ({:.1} %), interval coverage **{covc_ok} of {covc_n}** ({:.1} %), out-of-library named {oobc_named} of {oobc_n} ({:.1} %)\n",
        pct(libc_ok, libc_n),
        pct(covc_ok, covc_n),
        pct(oobc_named, oobc_n)
    );
    if pair_n > 0 {
        let _ = writeln!(
            md,
            "- two library effects at once (both named, nothing else): **{pair_ok} of {pair_n}** ({:.1} %); one of the two named and nothing else: {pair_one}\n",
            pct(pair_ok, pair_n)
        );
    }
    // Columns: the library effects named alone at least once on this channel (library
    // order), then several / ambiguous / unexplained / nothing.
    let mut cols: Vec<String> = EffectKind::ALL
        .iter()
        .filter(|k| rows.iter().any(|(_, r)| r.named == [**k]))
        .map(|k| k.name().to_string())
        .collect();
    let never: Vec<&str> = EffectKind::ALL
        .iter()
        .map(|k| k.name())
        .filter(|n| !cols.iter().any(|c| c == n))
        .collect();
    cols.extend(["several", "ambiguous", "unexplained", "nothing"].map(String::from));
    // Rows in the evaluation's order (null, in library, out of library, pairs).
    let mut order: Vec<(usize, String)> = Vec::new();
    let mut cells: HashMap<String, BTreeMap<String, usize>> = HashMap::new();
    let mut enrs: HashMap<String, Vec<f64>> = HashMap::new();
    let mut enrs_cal: HashMap<String, Vec<f64>> = HashMap::new();
    let mut several: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    for (h, r) in rows {
        let l = h.label();
        if !order.iter().any(|(_, o)| *o == l) {
            order.push((group(h), l.clone()));
        }
        *cells
            .entry(l.clone())
            .or_default()
            .entry(r.column())
            .or_default() += 1;
        enrs.entry(l.clone()).or_default().push(r.enr);
        if let Some(e) = r.enr_cal {
            enrs_cal.entry(l.clone()).or_default().push(e);
        }
        if r.named.len() > 1 {
            *several
                .entry(l)
                .or_default()
                .entry(r.outcome())
                .or_default() += 1;
        }
    }
    order.sort_by_key(|(g, _)| *g);
    let _ = writeln!(
        md,
        "| group | hidden effect | cases | median ENR | median ENR after calibration | {} |",
        cols.join(" | ")
    );
    let _ = writeln!(md, "|---|---|---:|---:|---:|{}", "---:|".repeat(cols.len()));
    for (g, l) in &order {
        let m = &cells[l];
        let n: usize = m.values().sum();
        let e = median(enrs.get_mut(l).map(|v| v.as_mut_slice()).unwrap_or(&mut []));
        let ec = median(
            enrs_cal
                .get_mut(l)
                .map(|v| v.as_mut_slice())
                .unwrap_or(&mut []),
        );
        let c: Vec<String> = cols
            .iter()
            .map(|c| m.get(c).map(|x| x.to_string()).unwrap_or_default())
            .collect();
        let gname = ["null", "in library", "out of library", "two in library"][*g];
        let _ = writeln!(
            md,
            "| {gname} | {l} | {n} | {e:.1} | {ec:.1} | {} |",
            c.join(" | ")
        );
    }
    let _ = writeln!(md);
    if !never.is_empty() {
        let _ = writeln!(
            md,
            "Library effects never named alone on this channel (no column): {}.",
            never.join(", ")
        );
    }
    if !several.is_empty() {
        let s: Vec<String> = several
            .iter()
            .map(|(l, m)| {
                let c: Vec<String> = m.iter().map(|(o, n)| format!("{o} ×{n}")).collect();
                format!("{l}: {}", c.join(", "))
            })
            .collect();
        let _ = writeln!(
            md,
            "\"several\" (more than one effect named): {}.",
            s.join("; ")
        );
    }
    let _ = writeln!(md);
    md
}

pub fn main() {
    let args: Vec<String> = crate::args().skip(1).collect();
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
    // --path board: `acc run` logs from `acc board-sim`, one closed loop at a time.
    let board_path = get("--path").as_deref() == Some("board");
    let threads = if board_path {
        1
    } else {
        num("--threads", 2).max(1) as usize
    };
    // --replay logged: analyse on the logs' own depths (no workpiece: not an exact replay,
    // as on a real machine); --rules off: no withholding rule (the rules' own effect).
    let how = CaseAnalysis {
        on_workpiece: get("--replay").as_deref() != Some("logged"),
        withhold_on_structure: match get("--rules").as_deref() {
            Some("off") => None,
            _ => CaseAnalysis::default().withhold_on_structure,
        },
    };
    let acc = std::path::PathBuf::from(get("--acc").unwrap_or_else(|| "target/release/acc".into()));
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
    // --only LABEL-PREFIX[,…]: only these effects (and the nulls) — a quick look.
    let only: Vec<String> = get("--only")
        .map(|s| s.split(',').map(str::to_string).collect())
        .unwrap_or_default();
    let out = std::path::PathBuf::from(get("--out").unwrap_or_else(|| "out/twin".into()));
    let doc = get("--update-doc");
    std::fs::create_dir_all(&out).expect("out dir");
    let dir = acc_sim::run::configs_dir();
    let mut base =
        acc_sim::Scenario::load(dir.join("scenarios/paper_case3.toml")).expect("scenario");
    base.max_time_s = max_time;
    if board_path {
        // The production model the board's logs are analysed against has no wear: the
        // paper tool's own slow wear would be an effect hidden in every case.
        base.wear = acc_sim::process::WearSpec {
            initial_factor: 1.0,
            growth_per_cm3: 0.0,
            growth_per_min: 0.0,
            ..base.wear
        };
    }
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
        for (set, seeds) in [
            (library(), lib_seeds),
            (out_of_library(), oob_seeds),
            (pairs(), lib_seeds),
        ] {
            for h in set {
                let l = h.label();
                if !h.acts_on(ch, estimated)
                    || (board_path && h.on_logging_path())
                    || skip.iter().any(|p| l.starts_with(p))
                    || (!only.is_empty() && !only.iter().any(|p| l.starts_with(p)))
                {
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
    let key_of = |&(ch, h, wi, seed): &(Channel, Hidden, usize, u64)| -> Key {
        (
            format!("{ch:?}"),
            h.label(),
            WORKPIECES[wi].to_string(),
            seed,
        )
    };
    // --resume FILE: the rows of a run stopped early; their cases are not run again.
    let mut done: HashMap<Key, Row> = HashMap::new();
    if let Some(f) = get("--resume") {
        let text = std::fs::read_to_string(&f).unwrap_or_else(|e| panic!("--resume {f}: {e}"));
        done.extend(text.lines().filter_map(parse_row));
    }
    let mut results: Vec<Option<Row>> = cases.iter().map(|c| done.remove(&key_of(c))).collect();
    let resumed = results.iter().filter(|r| r.is_some()).count();
    // cases.csv: the header and the resumed rows now, every further case as it finishes.
    let csv_path = out.join("cases.csv");
    let finished = |results: &[Option<Row>]| {
        csv_text(
            cases
                .iter()
                .zip(results)
                .filter_map(|(c, r)| r.as_ref().map(|r| (key_of(c), r)))
                .collect::<Vec<_>>()
                .into_iter(),
        )
    };
    std::fs::write(&csv_path, finished(&results)).expect("write cases.csv");
    let csv_file = Mutex::new(
        std::fs::OpenOptions::new()
            .append(true)
            .open(&csv_path)
            .expect("open cases.csv"),
    );
    // --report-only (with --resume): the figures of the rows there, nothing run; the
    // report says how many of the cases finished.
    let report_only = args.iter().any(|a| a == "--report-only");
    let todo: Vec<usize> = (0..cases.len())
        .filter(|&i| results[i].is_none() && !report_only)
        .collect();
    eprintln!(
        "{} cases, {resumed} resumed from earlier rows, {} to run on {threads} threads",
        cases.len(),
        todo.len()
    );
    let t0 = std::time::Instant::now();
    // The case's scenario: the base on its workpiece.
    let scenario_of = |wi: usize| {
        let mut s = base.clone();
        s.workpiece = wps[wi].clone();
        s
    };
    let board = board::BoardPath {
        acc: acc.clone(),
        out: out.clone(),
        machine_s: max_time,
    };
    let fresh: Mutex<Vec<(usize, Row)>> = Mutex::new(Vec::new());
    parallel(&todo, threads, |i| {
        let (ch, h, wi, seed) = cases[i];
        let verdict = if board_path {
            let wp = WORKPIECES[wi].trim_end_matches(".toml");
            board.run_case(&scenario_of(wi), h, ch, seed, wp)
        } else {
            run_case_with(&scenario_of(wi), h, ch, seed, how)
        };
        match verdict {
            Ok(v) => {
                let row = Row::of(&v);
                let line = csv_row(&key_of(&cases[i]), &row);
                eprintln!(
                    "[{i}/{}] {:.0} s {ch:?} {} {} seed {seed}: {} (ENR {:.1})",
                    cases.len(),
                    t0.elapsed().as_secs_f64(),
                    h.label(),
                    WORKPIECES[wi],
                    row.outcome(),
                    row.enr
                );
                if let Ok(mut f) = csv_file.lock() {
                    let _ = writeln!(f, "{line}");
                    let _ = f.flush();
                }
                if let Ok(mut r) = fresh.lock() {
                    r.push((i, row));
                }
            }
            Err(e) => eprintln!("{ch:?} {} {} {seed}: {e}", h.label(), WORKPIECES[wi]),
        }
    });
    for (i, r) in fresh.into_inner().expect("results") {
        results[i] = Some(r);
    }
    // Resumed rows of an older run lack the ENR after calibration: compute it (their
    // verdicts are not re-run) and rewrite cases.csv with it.
    let missing: Vec<usize> = (0..cases.len())
        .filter(|&i| results[i].as_ref().is_some_and(|r| r.enr_cal.is_none()))
        .collect();
    if !missing.is_empty() {
        eprintln!(
            "{} resumed rows without the ENR after calibration: computing it",
            missing.len()
        );
        let got: Mutex<Vec<(usize, f64)>> = Mutex::new(Vec::new());
        parallel(&missing, threads, |i| {
            let (ch, h, wi, seed) = cases[i];
            match twin::calibrated_effect_to_noise(&scenario_of(wi), h, ch, seed) {
                Ok(e) => {
                    if let Ok(mut g) = got.lock() {
                        g.push((i, e));
                    }
                }
                Err(e) => eprintln!("{ch:?} {} {}: {e}", h.label(), WORKPIECES[wi]),
            }
        });
        for (i, e) in got.into_inner().expect("results") {
            if let Some(r) = results[i].as_mut() {
                r.enr_cal = Some(e);
            }
        }
        std::fs::write(&csv_path, finished(&results)).expect("write cases.csv");
    }
    let elapsed = t0.elapsed().as_secs_f64();
    let mut md = String::new();
    let _ = writeln!(
        md,
        "Columns: the library effect named (alone); \"several\": more than one named (the \
         combinations are listed under the table); \"ambiguous\": nothing named, two \
         candidates explain the same residual; \"unexplained\": nothing named, structure \
         remains; \"nothing\": nothing named and the nominal model explains the log. ENR: \
         the case's effect-to-noise ratio (`twin::effect_to_noise`: the nominal replay's \
         residual on the log with vs without the effect, same workpiece and seed); after \
         calibration: the same with `Ks` and the no-load offset refitted to each log \
         (`twin::calibrated_effect_to_noise`).\n"
    );
    for &ch in &channels {
        let rows: Vec<(Hidden, &Row)> = cases
            .iter()
            .zip(&results)
            .filter(|(c, _)| c.0 == ch)
            .filter_map(|(c, r)| r.as_ref().map(|r| (c.1, r)))
            .collect();
        let name = if ch == Channel::Power {
            "power"
        } else {
            "force"
        };
        md.push_str(&channel_md(name, &rows));
    }
    let finished = results.iter().filter(|r| r.is_some()).count();
    let _ = writeln!(
        md,
        "{null_seeds} null seeds per channel (spread over {nwp} shipped workpieces), {lib_seeds} seed(s) × {nwp} workpieces per in-library cell and pair, {oob_seeds} seed(s) × {nwp} workpieces per out-of-library cell; {finished} of {} cases finished ({resumed} resumed from an earlier run); {elapsed:.0} s on {threads} threads (release build) for the rest.{}",
        cases.len(),
        if board_path {
            " Logs: `acc run` controlling `acc board-sim` over a pty (4× time), one closed loop per case for both channels; verdicts: `acc discrepancy --workpiece` against `paper_vmc_production.toml`; the logging-path effects are not run on this path (they act on the logged column after the run, the same on either path); ENR: the same case's on `acc sim`'s log."
        } else {
            ""
        }
    );
    std::fs::write(out.join("twin.md"), &md).expect("write");
    println!("{md}");
    if let Some(doc) = doc {
        let text = std::fs::read_to_string(&doc).unwrap_or_default();
        let (a, b) = if board_path {
            (
                "<!-- twin-eval-board:begin -->",
                "<!-- twin-eval-board:end -->",
            )
        } else {
            ("<!-- twin-eval:begin -->", "<!-- twin-eval:end -->")
        };
        let new = match (text.find(a), text.find(b)) {
            (Some(i), Some(j)) if j > i => format!("{}{a}\n{md}{}", &text[..i], &text[j..]),
            _ => format!("{text}\n{a}\n{md}{b}\n"),
        };
        std::fs::write(&doc, new).expect("write doc");
    }
    println!(
        "total time: {elapsed:.1} s for {} cases run ({resumed} resumed)",
        todo.len()
    );
}
