//! Tool wear on the long 3 mm cut (configs/scenarios/tool_wear.toml: Ks grows by
//! 1.5 %/cm³ over 28.8 cm³, i.e. ×1.43): Kc_hat rises with the wear while the force stays
//! regulated at Fr = 800 N.

use acc_runtime::record::RunRecord;
use acc_sim::run::configs_dir;
use acc_sim::{LawKind, Scenario};

fn window(rows: &[RunRecord], t0: f64, t1: f64) -> Vec<&RunRecord> {
    rows.iter().filter(|r| r.t_s >= t0 && r.t_s < t1).collect()
}

fn mean(xs: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = xs.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    s / n.max(1) as f64
}

#[test]
fn kc_hat_rises_with_wear_while_force_stays_regulated() {
    let sc = Scenario::load(configs_dir().join("scenarios/tool_wear.toml")).expect("scenario");
    let (run, sum) = sc.run_law(LawKind::Ours).expect("run");
    assert!(run.finished);
    let cut = sum.segments.iter().find(|s| s.is_cut).expect("cut");
    let span = cut.t_leave_s - cut.t_enter_s;
    let early = window(&run.rows, cut.t_enter_s + 3.0, cut.t_enter_s + 0.15 * span);
    let late = window(&run.rows, cut.t_leave_s - 0.15 * span, cut.t_leave_s - 1.0);

    // True process gain in each window: F_true / feed (β = 1, so Kc = F/f exactly).
    let kc_true = |w: &[&RunRecord]| {
        mean(
            w.iter()
                .filter_map(|r| Some(r.force_true_n? / r.feed_true_mm_min?)),
        )
    };
    let kc_hat = |w: &[&RunRecord]| mean(w.iter().filter_map(|r| r.kc_hat));
    let (t0, t1) = (kc_true(&early), kc_true(&late));
    let (h0, h1) = (kc_hat(&early), kc_hat(&late));
    // Wear grew Kc by about 30 % between the windows (0.15 → 0.85 of 28.8 cm³ at 1.5 %/cm³
    // on a base of ~1.07): the estimate follows the truth within 3 %.
    assert!(t1 / t0 > 1.25, "true Kc {t0:.2} → {t1:.2}");
    assert!(
        (h0 / t0 - 1.0).abs() < 0.03,
        "early Kc_hat {h0:.3} vs true {t0:.3}"
    );
    assert!(
        (h1 / t1 - 1.0).abs() < 0.03,
        "late Kc_hat {h1:.3} vs true {t1:.3}"
    );
    assert!(h1 / h0 > 1.25);

    // The force stays at Fr: the mean of each window within ±5 %.
    for w in [&early, &late] {
        let f = mean(w.iter().filter_map(|r| r.force_n));
        assert!((f - 800.0).abs() < 40.0, "mean force {f:.1}");
    }
    // ... and the feed had to come down to hold it.
    let feed = |w: &[&RunRecord]| mean(w.iter().filter_map(|r| r.feed_true_mm_min));
    assert!(feed(&late) < 0.85 * feed(&early));
}
