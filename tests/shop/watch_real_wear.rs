//! The wear watch on real data: the Vicomtech / Mondragon turning tool-wear set
//! (`../shared/data/vicomtech-turning`, CC BY-SA 4.0; Ferrando Chacón et al., Int. J. Adv.
//! Manuf. Technol. 125, 2023): seven tools run until worn, one row per second with the
//! dynamometer's cutting force, the programmed feed, the spindle speed and the measured
//! flank wear Vb.
//!
//! Each second becomes a run-log record for [`WearTracker`]: the tool number, the cutting
//! condition (spindle-speed level; the NC block that set it) as the block, and Kc = F_c /
//! feed — the static gain Kc_hat converges to (seed 002 eq. 1, β = 1). The data are open
//! loop (no force reference), so every cutting second counts as steady (Fr = the force).
//! Kc depends on the cutting speed as much as on the edge, which is why the watch keeps one
//! fresh reference per tool *and* cut: within each condition the trend must rise with Vb.
//!
//! Skips with a reason when the data are absent; fails under `CI`.

use std::collections::BTreeMap;

use acc_runtime::record::RunRecord;
use acc_runtime::watch::{WatchLimits, WearTracker};
use acc_spindle::datasets::read_turning;

/// (Kc trend point, Vb at the window's end in µm, rise over the fresh reference in %), per
/// (tool, block).
type Point = (f64, f64, f64);

fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

#[test]
fn the_kc_trend_rises_with_flank_wear_on_real_turning_data() {
    let Some(dir) = crate::real_data::shared_data("vicomtech-turning") else {
        return;
    };
    let (rows, _skipped) =
        read_turning(&dir.join("tool_wear_tools_3-10.csv")).expect("turning data");
    let limits = WatchLimits {
        wear_window_periods: 5,
        ..WatchLimits::default()
    };
    let mut tracker = WearTracker::new(limits);
    let mut groups: BTreeMap<(u16, u16), Vec<Point>> = BTreeMap::new();
    for (i, r) in rows.iter().enumerate() {
        let block = (r.speed / 1e6).round() as u16;
        let rec = RunRecord {
            t_s: i as f64,
            tool: Some(r.tool as u16),
            program: Some(1),
            block: Some(block),
            x_mm: Some(i as f64),
            force_n: Some(r.force_n),
            force_valid: true,
            force_ref_n: Some(r.force_n),
            kc_hat: Some(r.force_n / r.feed),
            state: "active".into(),
            saturation: "none".into(),
            ..RunRecord::default()
        };
        if let Some(s) = tracker.observe(&rec) {
            groups
                .entry((s.tool, s.block))
                .or_default()
                .push((s.kc, r.vb_um, s.rise_pct));
        }
    }
    let mut judged = 0;
    let mut rising = 0;
    let mut correlated = 0;
    for ((tool, block), pts) in &groups {
        let vb0 = pts.first().map_or(0.0, |p| p.1);
        let vb1 = pts.last().map_or(0.0, |p| p.1);
        // Conditions in which the edge wore measurably (Vb up by 20 µm or more).
        if pts.len() < 4 || vb1 - vb0 < 20.0 {
            continue;
        }
        judged += 1;
        let kc: Vec<f64> = pts.iter().map(|p| p.0).collect();
        let vb: Vec<f64> = pts.iter().map(|p| p.1).collect();
        let r = pearson(&kc, &vb);
        let rise = pts.last().map_or(0.0, |p| p.2);
        println!(
            "tool {tool} condition {block}: Vb {vb0:.0} → {vb1:.0} µm, Kc trend {:+.1} %, r(Kc, Vb) = {r:.2} ({} points)",
            rise,
            pts.len()
        );
        if rise > 0.0 {
            rising += 1;
        }
        if r > 0.5 {
            correlated += 1;
        }
    }
    assert!(
        judged >= 12,
        "{judged} tool conditions with measurable wear"
    );
    // The trend rises with the flank wear in every condition, and follows it closely
    // (r > 0.5) in nearly all.
    assert_eq!(rising, judged, "the Kc trend rose in {rising} of {judged}");
    assert!(
        correlated * 10 >= judged * 8,
        "r(Kc, Vb) > 0.5 in {correlated} of {judged}"
    );
}
