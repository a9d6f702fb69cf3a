//! Property tests: for random stocks, cutters and paths the engagement stays in range and
//! the reported volumes add up to what the stock lost.

use acc_stock::{Cutter, Move, Rotation, Spindle, StepKind, Sweep, SweepOptions, ZMap};
use proptest::prelude::*;

fn point() -> impl Strategy<Value = [f64; 3]> {
    (-10.0f64..60.0, -10.0f64..50.0, -6.0f64..2.0).prop_map(|(x, y, z)| [x, y, z])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn engagement_is_in_range_and_volume_is_conserved(
        d in 2.0f64..16.0,
        flutes in 1usize..7,
        flute_len in 1.0f64..10.0,
        ccw in any::<bool>(),
        ball in any::<bool>(),
        bins in 8usize..240,
        exact_moves in 0usize..6,
        pocket in (0.0f64..30.0, 0.0f64..20.0, 2.0f64..20.0, 2.0f64..20.0, -5.0f64..0.0),
        path in prop::collection::vec((point(), any::<bool>()), 2..7),
    ) {
        let mut stock = ZMap::from_box([0.0, 0.0, -5.0], [50.0, 40.0, 0.0], 0.5).expect("box");
        let (px, py, w, h, z) = pocket;
        stock.lower_rect([px, py], [px + w, py + h], z);
        let before = stock.volume_mm3();
        let cutter = if ball {
            Cutter::ball(d, flutes, flute_len)
        } else {
            Cutter::flat(d, flutes, flute_len)
        }
        .expect("cutter");
        let spindle = Spindle {
            rpm: 3000.0,
            rotation: if ccw { Rotation::CounterClockwise } else { Rotation::Clockwise },
        };
        let options = SweepOptions { angular_bins: bins, exact_moves, ..SweepOptions::default() };
        let mut s = Sweep::new(stock, cutter, spindle, options).expect("sweep");
        let mut out = Vec::new();
        for w in path.windows(2) {
            let (from, to, rapid) = (w[0].0, w[1].0, w[1].1);
            s.cut(&Move { from, to, feed_mm_min: 500.0, rapid }, &mut out);
        }
        let pi = std::f64::consts::PI;
        let mut removed = 0.0;
        for e in &out {
            prop_assert!(0.0 <= e.entry_rad && e.entry_rad <= e.exit_rad && e.exit_rad <= pi + 1e-12);
            prop_assert!(e.span_rad >= 0.0 && e.span_rad <= e.exit_rad - e.entry_rad + 1e-9);
            prop_assert!(e.ae_mm >= 0.0 && e.ae_mm <= d + 1e-9, "{:?}", e);
            prop_assert!(e.radial_mm >= 0.0 && e.radial_mm <= e.ae_mm + 1e-9);
            prop_assert!(e.ap_mm >= 0.0 && e.ap_mm <= flute_len + 1e-9);
            prop_assert!(e.removed_mm3 >= 0.0);
            prop_assert!(e.arcs as usize <= bins.div_ceil(2));
            prop_assert_eq!(e.arcs == 0, e.span_rad == 0.0);
            prop_assert!(e.chip_max_mm <= e.feed_per_tooth_mm + 1e-12);
            match e.kind {
                StepKind::Air => prop_assert!(e.arcs == 0 && e.ae_mm == 0.0 && e.ap_mm == 0.0),
                StepKind::Cut => prop_assert!(e.arcs > 0 && !e.rapid),
                StepKind::Plunge => prop_assert!(e.arcs == 0 && e.ae_mm == 0.0 && !e.rapid),
                StepKind::RapidCollision => prop_assert!(e.rapid),
            }
            removed += e.removed_mm3;
        }
        let lost = before - s.stock().volume_mm3();
        prop_assert!((removed - lost).abs() <= 1e-6 * before, "{} vs {}", removed, lost);
    }
}
