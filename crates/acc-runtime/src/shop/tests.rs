//! Entry control on a plant whose force is k × applied: the limiter's peaks and the
//! learning at the exit.

use super::*;
use proptest::prelude::*;

const TABLE: &str = "[entry]\nenabled = true\nlimit_pct = 8.0\n[default]\nfr_n = 800.0\n";

fn status(applied: u16) -> BoardStatus {
    BoardStatus {
        override_applied_pct: applied,
        override_step_pct: 10,
        protocol_version: 2,
        tool_number: 1,
        block_number: 20,
        cycle_active: true,
        acc_active: true,
        ..BoardStatus::default()
    }
}

/// The shop layer on a plant whose force is k(i) × applied, the law asking 150 % every
/// period and the command floored to the 10 % grid (as the policy does): the forces.
fn entry(shop: &mut ShopControl, ks: &[f64]) -> Vec<f64> {
    let mut applied = 150u16;
    let mut forces = Vec::new();
    for &k in ks {
        let f = k * f64::from(applied);
        forces.push(f);
        let sample = ForceSample {
            force_n: f,
            power_w: None,
            valid: true,
        };
        let lim = shop.before(Some(&status(applied)), &sample, Some(applied), None);
        let cap = lim.limits.cap_pct.unwrap_or(150);
        applied = 150.min(cap / 10 * 10);
    }
    forces
}

fn shop() -> ShopControl {
    let table = ToolTable::parse("tools.toml", TABLE).expect("table");
    ShopControl::new(table, 0.1)
}

/// A decelerating engagement (growth per period non-increasing): air for 5 periods,
/// then k = k_full (1 − (1 − i/n)^p) for i = 1 ..= n periods (p ≥ 1), then k_full.
fn ramp(k_full: f64, n: u32, p: f64) -> Vec<f64> {
    let mut ks = vec![0.0; 5];
    for i in 1..=n {
        ks.push(k_full * (1.0 - (1.0 - f64::from(i) / f64::from(n)).powf(p)));
    }
    ks.resize(60, k_full);
    ks
}

#[test]
fn entry_drops_the_override_as_the_predicted_force_reaches_the_limit() {
    // Like the interrupted cut's entry at 300 mm/min: k 0.85, 2.98, 4.77, 6.29 ... 12 N/%.
    let ks = ramp(12.0, 12, 2.0);
    let mut sh = shop();
    let f = entry(&mut sh, &ks);
    let peak = f.iter().copied().fold(0.0, f64::max);
    assert!(peak <= 864.0 + 1e-9, "peak {peak:.1} N");
    // It ran in at 150 % while the engagement was small, and ends near Fr.
    assert!(f[5] > 0.0 && f[6] > 1.5 * f[5], "{:?}", &f[..10]);
    assert!(*f.last().expect("f") > 700.0, "{:?}", f.last());
    assert_eq!(sh.state(), ShopState::Cut);
}

#[test]
fn learning_at_the_exit_and_carried_into_the_next_run() {
    let mut ks = ramp(12.0, 12, 2.0);
    ks.extend([0.0; 4]);
    let mut sh = shop();
    entry(&mut sh, &ks);
    assert_eq!(sh.state(), ShopState::Air);
    // Fr / 12 N/% = 66.7 %, floored.
    assert_eq!(sh.learned_entry(1, 20), Some(66));
    assert_eq!(
        sh.entry_override(1, 30),
        Some(66),
        "the tool's, in another block"
    );
    let next = shop().with_learned_from(&sh);
    assert_eq!(next.learned_entry(1, 20), Some(66));
    assert_eq!(next.state(), ShopState::Air);
}

proptest! {
    /// On any decelerating engagement that completes within the entry window (`n` ≤
    /// 14 periods) and whose first period at the air override (150 %) stays under the
    /// limit (what `air_override_pct` is for), the predictive limiter keeps every
    /// period's force under Fr (1 + limit_pct/100).
    #[test]
    fn no_entry_overshoots_a_decelerating_engagement(
        k_full in 2.0f64..20.0,
        n in 2u32..=14,
        p in 1.0f64..4.0,
    ) {
        let ks = ramp(k_full, n, p);
        prop_assume!(ks[5] * 150.0 <= 864.0);
        let mut sh = shop();
        let f = entry(&mut sh, &ks);
        let peak = f.iter().copied().fold(0.0, f64::max);
        prop_assert!(peak <= 864.0 + 1e-6, "peak {} N", peak);
    }
}
