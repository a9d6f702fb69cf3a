//! Issue 13, item 2: the library additions `depth_exponent`, `ks_step` and
//! `second_order_drive`. For each, a log from `acc sim`'s production loop with the effect in
//! the simulated machine (a) replays to within the noise with the candidate at the true
//! value on the model's side, and (b) is named by the workflow with an interval that covers
//! the truth.

use acc_ident::effects::EffectKind;
use acc_ident::model::Channel;
use acc_ident::twin::{self, run_case, Hidden};

fn scenario(workpiece: &str) -> acc_sim::Scenario {
    let dir = acc_sim::run::configs_dir();
    let mut sc = acc_sim::Scenario::load(dir.join("scenarios/paper_case3.toml")).expect("scenario");
    sc.workpiece = acc_sim::Workpiece::load(dir.join("workpieces").join(workpiece)).expect("wp");
    sc.max_time_s = 60.0;
    sc
}

/// Robust noise σ of a residual: MAD of first differences / (0.6745·√2).
fn sigma(r: &[f64]) -> f64 {
    let mut d: Vec<f64> = r.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    d.sort_by(f64::total_cmp);
    d[d.len() / 2] / 0.6745 / 2f64.sqrt()
}

fn rms(r: &[f64]) -> f64 {
    (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt()
}

/// Replay RMS of `hidden`'s log by the nominal model and by the model with `kind` set to
/// `values` (parameter index, value), and the noise σ, on `channel`.
fn replay_with(
    wp: &str,
    hidden: Hidden,
    channel: Channel,
    kind: EffectKind,
    values: &dyn Fn(&acc_sim::Scenario) -> Vec<(usize, f64)>,
) -> (f64, f64, f64) {
    let base = scenario(wp);
    let (mut sc, model, wp) = twin::hidden_case(&base, hidden, channel);
    sc.seed = 1000;
    let log = twin::simulate(&sc).expect("log");
    let r0 = twin::replay_residual(&model, &log, Some((&wp, 0.0))).expect("replay");
    let mut m = model.clone();
    for (i, v) in values(&base) {
        m.effects.set(kind, i, v);
    }
    let r1 = twin::replay_residual(&m, &log, Some((&wp, 0.0))).expect("replay");
    (rms(&r0), rms(&r1), sigma(&r1).max(0.5))
}

#[test]
fn the_replay_with_the_new_candidates_at_the_truth_is_the_simulator() {
    let ch = Channel::Power;
    // Depth exponent α = 1.15 on a 2-3-4 mm part: Δα = 0.15.
    let (before, after, s) = replay_with(
        "steps_2_3_4.toml",
        Hidden::DepthExponent(1.15),
        ch,
        EffectKind::DepthExponent,
        &|b| vec![(0, 1.15 - b.tool.process.alpha)],
    );
    assert!(
        before > 10.0 * s,
        "depth exponent: nominal {before:.2} vs σ {s:.2}"
    );
    assert!(after <= 1.6 * s, "depth exponent: {after:.2} vs σ {s:.2}");
    // Second-order drive τ₂ = 0.15 s.
    let (before, after, s) = replay_with(
        "steps_2_3_4.toml",
        Hidden::SecondOrderDrive(0.15),
        ch,
        EffectKind::SecondOrderDrive,
        &|_| vec![(0, 0.15)],
    );
    assert!(before > 10.0 * s, "τ₂: nominal {before:.2} vs σ {s:.2}");
    assert!(after <= 1.6 * s, "τ₂: {after:.2} vs σ {s:.2}");
    // Ks × 1.3 from the second cut segment on (x = 55 mm): the boundary fraction that puts
    // it there, from the boundary the replay reports at fractions 0 and 1.
    let base = scenario("steps_2_3_4.toml");
    let (mut sc, model, wp) = twin::hidden_case(&base, Hidden::KsStep(1.3), ch);
    sc.seed = 1000;
    let log = twin::simulate(&sc).expect("log");
    let b_true = wp
        .segments
        .iter()
        .filter(|g| g.is_cut())
        .nth(1)
        .expect("second cut")
        .start_mm;
    let boundary = |frac: f64| {
        let mut m = model.clone();
        m.effects.set(EffectKind::KsStep, 0, 0.3);
        m.effects.set(EffectKind::KsStep, 1, frac);
        let mut inp = acc_ident::replay::Inputs::from_log(&log, &m).expect("inputs");
        inp.use_workpiece(wp.clone(), 0.0);
        let r = acc_ident::replay::replay(&m, &inp);
        let res: Vec<f64> = inp
            .measured
            .iter()
            .zip(&r.predicted)
            .map(|(a, b)| a - b)
            .collect();
        (r.ks_step_boundary_mm.expect("boundary"), res)
    };
    let (b0, _) = boundary(0.0);
    let (b1, _) = boundary(1.0);
    let frac = (b_true - b0) / (b1 - b0);
    let (b, res) = boundary(frac);
    assert!((b - b_true).abs() < 1e-9, "{b} vs {b_true}");
    let r0 = twin::replay_residual(&model, &log, Some((&wp, 0.0))).expect("replay");
    let s = sigma(&res).max(0.5);
    assert!(
        rms(&r0) > 10.0 * s,
        "ks step: nominal {:.2} vs σ {s:.2}",
        rms(&r0)
    );
    assert!(
        rms(&res) <= 1.6 * s,
        "ks step: {:.2} vs σ {s:.2}",
        rms(&res)
    );
}

#[test]
fn a_depth_exponent_in_the_machine_is_named_with_its_interval() {
    let v = run_case(
        &scenario("steps_2_3_4.toml"),
        Hidden::DepthExponent(0.85),
        Channel::Power,
        1000,
    )
    .expect("case");
    assert_eq!(v.named, vec![EffectKind::DepthExponent], "{v:?}");
    assert_eq!(v.covered, Some(true), "{v:?}");
}

#[test]
fn a_ks_step_in_the_material_is_named_with_its_interval() {
    for (k, ch) in [(1.3, Channel::Power), (0.8, Channel::Force)] {
        let v = run_case(&scenario("steps_2_3_4.toml"), Hidden::KsStep(k), ch, 1000).expect("case");
        assert_eq!(v.named, vec![EffectKind::KsStep], "×{k} {ch:?}: {v:?}");
        assert_eq!(v.covered, Some(true), "×{k} {ch:?}: {v:?}");
    }
}

#[test]
fn a_second_order_drive_is_named_with_its_interval() {
    let v = run_case(
        &scenario("steps_2_3_4.toml"),
        Hidden::SecondOrderDrive(0.15),
        Channel::Power,
        1000,
    )
    .expect("case");
    assert_eq!(v.named, vec![EffectKind::SecondOrderDrive], "{v:?}");
    assert_eq!(v.covered, Some(true), "{v:?}");
}

#[test]
fn the_new_candidates_are_library_effects() {
    for (k, n) in [
        (EffectKind::DepthExponent, "depth_exponent"),
        (EffectKind::KsStep, "ks_step"),
        (EffectKind::SecondOrderDrive, "second_order_drive"),
    ] {
        assert_eq!(EffectKind::from_name(n), Some(k));
        assert!(EffectKind::ALL.contains(&k));
        assert!(acc_ident::workflow::Options::default()
            .candidates
            .contains(&k));
    }
    // TOML round trip of the `[effects.<name>]` sections.
    let text = "[ks_step]\ndelta = 0.3\nboundary_frac = 0.4\n[depth_exponent]\ndelta_alpha = -0.1\n[second_order_drive]\ntau2_s = 0.12\n";
    let e: acc_ident::effects::Effects = toml::from_str(text).expect("toml");
    assert_eq!(e.get(EffectKind::KsStep, 1), 0.4);
    assert_eq!(e.get(EffectKind::DepthExponent, 0), -0.1);
    assert_eq!(e.get(EffectKind::SecondOrderDrive, 0), 0.12);
    let back: acc_ident::effects::Effects =
        toml::from_str(&toml::to_string(&e).expect("ser")).expect("de");
    assert_eq!(back, e);
    assert!(e.validate(std::path::Path::new("m.toml")).is_ok());
    let mut bad = e.clone();
    bad.set(EffectKind::KsStep, 0, 3.0);
    let Err(err) = bad.validate(std::path::Path::new("m.toml")) else {
        panic!("a ks_step delta of 3 passed validation");
    };
    assert!(err.to_string().contains("effects.ks_step.delta"), "{err}");
}
