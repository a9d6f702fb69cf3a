//! The tooth-level force model (seed 004): ripple at the tooth-pass frequency, the same
//! mean as eq. (1), and a closed loop that regulates just as with the mean-force model
//! because the dynamometer averages two whole tooth passes.

use acc_sim::run::configs_dir;
use acc_sim::{ForceModel, LawKind, Scenario};

#[test]
fn tooth_model_ripples_around_the_mean_force() {
    let sc =
        Scenario::load(configs_dir().join("scenarios/paper_case3_tooth.toml")).expect("scenario");
    assert_eq!(sc.force_model, ForceModel::Tooth);
    let mut board = sc.build_board();
    // 2 s at 100 % with the tool fully in the 2 mm step (start of the step at 15 mm; the
    // tool reaches 15 + 10 mm after 7.5 s at 200 mm/min).
    for _ in 0..80 {
        board.advance_period(0.1);
    }
    let rec = board.advance_period(0.1);
    assert!(rec.radial_depth_mm == 2.0, "depth {}", rec.radial_depth_mm);
    let f: Vec<f64> = rec.samples.iter().map(|s| s.force_n).collect();
    let mean = f.iter().sum::<f64>() / f.len() as f64;
    let (lo, hi) = f
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    // Mean of one revolution = eq. (1): 800 N at 2 mm, 200 mm/min (new tool, +<1 % wear).
    assert!((mean - 800.0).abs() < 0.015 * 800.0, "mean {mean:.1}");
    // Strong ripple: a flute is in the cut for 107° of a 90° pitch (tests in process.rs).
    assert!(hi > 1.2 * mean && lo < 0.5 * mean, "{lo:.0} … {hi:.0}");
    // Periodic with the tooth pitch: at 600 rpm and 10 kHz a revolution is 1000 samples and
    // a tooth pass 250. Shifting by one pass changes nothing (the feed is constant); shifting
    // by half a pass changes the force a lot.
    let n = f.len();
    assert_eq!(n, 1000);
    let shift_diff = |k: usize| {
        (0..n - k)
            .map(|i| (f[i] - f[i + k]).abs())
            .fold(0.0, f64::max)
    };
    assert!(
        shift_diff(250) < 0.01 * mean,
        "not periodic per tooth: {}",
        shift_diff(250)
    );
    assert!(
        shift_diff(125) > 0.3 * mean,
        "no ripple within a tooth pass"
    );
}

#[test]
fn tooth_model_loop_matches_the_mean_model_loop() {
    let sc_t =
        Scenario::load(configs_dir().join("scenarios/paper_case3_tooth.toml")).expect("scenario");
    let sc_m = Scenario {
        force_model: ForceModel::Mean,
        ..sc_t.clone()
    };
    let (_, st) = sc_t.run_law(LawKind::Ours).expect("run");
    let (_, sm) = sc_m.run_law(LawKind::Ours).expect("run");
    for (a, b) in st
        .segments
        .iter()
        .zip(&sm.segments)
        .filter(|(a, _)| a.is_cut)
    {
        assert!(
            (a.mean_force_n - b.mean_force_n).abs() < 10.0,
            "{}: {:.1} vs {:.1}",
            a.label,
            a.mean_force_n,
            b.mean_force_n
        );
        assert!((a.mean_override_pct - b.mean_override_pct).abs() < 2.0);
    }
    let (ct, cm) = (
        st.cycle_time_s.unwrap_or(0.0),
        sm.cycle_time_s.unwrap_or(1.0),
    );
    assert!((ct - cm).abs() < 0.5, "cycle {ct} vs {cm}");
}
