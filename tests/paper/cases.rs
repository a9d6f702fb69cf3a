//! Paper reproduction (seed 002), adaptive cases: I (poles 0.2, −0.05), II (0.1, −0.6),
//! III (0.001, −0.001) on the 2-3-4 mm steps and IV (case III poles) on the 2→4 mm ramp.
//!
//! Tolerances come from the 10 % override board: one step is Kc·20 mm/min of force
//! (80 / 120 / 160 N at 2 / 3 / 4 mm), so a regulated loop dithers between two positions
//! and its force spreads by about half a step around a mean that the integrator pulls to
//! Fr. "No sustained oscillation" is therefore an amplitude below 0.6 step plus 3σ of the
//! 5 N measurement noise; the unstable fixed-gain loop (tests/paper_fixed_gain.rs) swings
//! by more than 500 N.

use acc_sim::run::configs_dir;
use acc_sim::summary::{SegmentStats, Summary};
use acc_sim::{LawKind, RunResult, Scenario};

fn run(name: &str) -> (Scenario, RunResult, Summary) {
    let sc =
        Scenario::load(configs_dir().join(format!("scenarios/{name}.toml"))).expect("scenario");
    let (r, s) = sc.run_law(LawKind::Ours).expect("run");
    assert!(r.finished, "{name}: not finished");
    (sc, r, s)
}

/// Kc of a segment at the end of the run (calibration 4 N/(mm/min) per 2 mm, times wear).
fn kc_of(seg: &SegmentStats, wear: f64) -> f64 {
    let depth: f64 = seg
        .label
        .split_whitespace()
        .nth(1)
        .and_then(|d| d.split('→').next_back())
        .and_then(|d| d.parse().ok())
        .unwrap_or(4.0);
    2.0 * depth * wear
}

fn check_regulated(name: &str) -> Summary {
    let (_, run, sum) = run(name);
    let wear = 1.05; // < +5 % Ks over a paper workpiece at 0.5 %/cm³ (5.8 cm³)
    let noise = 5.0;
    for s in sum.segments.iter().filter(|s| s.is_cut) {
        assert!(s.reaches_ref, "{name} {}: Fr not reachable?", s.label);
        assert!(
            (s.mean_force_n - 800.0).abs() <= 0.05 * 800.0,
            "{name} {}: mean force {:.1} N not within ±5 % of 800 N",
            s.label,
            s.mean_force_n
        );
        let step_force = kc_of(s, wear) * 20.0;
        let bound = 0.6 * step_force + 3.0 * noise;
        assert!(
            s.osc_amplitude_n < bound,
            "{name} {}: oscillation amplitude {:.1} N ≥ {bound:.1} N",
            s.label,
            s.osc_amplitude_n
        );
    }
    // Air cuts before and after the part run at 150 %.
    for s in sum
        .segments
        .iter()
        .filter(|s| !s.is_cut && s.settled_periods > 0)
    {
        assert_eq!(
            s.frac_at_max, 1.0,
            "{name} {}: air cut below 150 %",
            s.label
        );
    }
    // The production loop arms ACC in its first period (bumpless, at the override in force)
    // and steps the law in every period after it, but the one in which the line guard holds
    // the read that first shows the program's end (CYCLE_ACTIVE falls: a STATUS change is
    // confirmed by the next read); no fault policy release in between.
    assert_eq!(run.rows[0].state, "active");
    assert!(run.rows[1..]
        .iter()
        .all(|r| r.state == "active"
            && (r.mode == "adaptive_pi" || r.has_flag("unconfirmed:status"))));
    assert!(run.rows.iter().filter(|r| r.mode.is_empty()).count() <= 2);
    sum
}

#[test]
fn case_1_regulates_every_step() {
    check_regulated("paper_case1");
}

#[test]
fn case_3_regulates_every_step() {
    check_regulated("paper_case3");
}

#[test]
fn case_4_regulates_the_ramp() {
    let sum = check_regulated("paper_case4");
    assert_eq!(sum.segments.iter().filter(|s| s.is_cut).count(), 1);
}

#[test]
fn case_2_is_more_oscillatory_than_case_3() {
    // Pole −0.6 rings: after each disturbance the error alternates in sign and decays only
    // by 0.6 per period, while case III is practically deadbeat. Measured on the same
    // workpiece and seed: force RMS error while cutting, the 4 mm segment's oscillation
    // amplitude, and the number of override switches.
    let (sc2, _, s2) = run("paper_case2");
    let sc3 = Scenario {
        seed: sc2.seed,
        ..Scenario::load(configs_dir().join("scenarios/paper_case3.toml")).expect("scenario")
    };
    let (_, s3) = sc3.run_law(LawKind::Ours).expect("run");
    assert!(
        s2.rms_error_cut_n > 1.2 * s3.rms_error_cut_n,
        "RMS error: case II {:.1} N, case III {:.1} N",
        s2.rms_error_cut_n,
        s3.rms_error_cut_n
    );
    let amp = |s: &Summary| {
        s.segments
            .iter()
            .find(|x| x.label == "cut 4.0 mm")
            .map(|x| x.osc_amplitude_n)
            .unwrap_or(0.0)
    };
    assert!(
        amp(&s2) > 1.3 * amp(&s3),
        "4 mm amplitude: II {:.1}, III {:.1}",
        amp(&s2),
        amp(&s3)
    );
    assert!(s2.override_switches > s3.override_switches);
}

#[test]
fn case_1_kc_hat_tracks_each_depth() {
    // Kc_hat converges to F/f of each segment: 4, 6, 8 N/(mm/min) at 2, 3, 4 mm (times
    // the slowly growing wear factor ≤ 1.05).
    let (_, run, sum) = run("paper_case1");
    for s in sum.segments.iter().filter(|s| s.is_cut) {
        let kc = kc_of(s, 1.0);
        let settled: Vec<f64> = run
            .rows
            .iter()
            .filter(|r| r.t_s > s.t_enter_s + 2.0 && r.t_s <= s.t_leave_s - 0.5)
            .filter_map(|r| r.kc_hat)
            .collect();
        let mean = settled.iter().sum::<f64>() / settled.len() as f64;
        assert!(
            mean > 0.98 * kc && mean < 1.07 * kc,
            "{}: Kc_hat {mean:.3} vs {kc}",
            s.label
        );
    }
}
