//! The breakage detector runs inside the fault policy's step on the control thread: it does
//! not allocate (a counting global allocator, this test binary only, sees zero allocations
//! on the thread while it judges steady cuts, entries, exits, drops and spikes).
#![allow(clippy::unwrap_used)]

use acc_runtime::watch::{BreakageDetector, BreakageSample, WatchLimits};

use crate::counting_alloc::allocations;

#[test]
fn breakage_detector_does_not_allocate() {
    let probe = allocations();
    let v = std::hint::black_box(vec![1u8; 16]);
    assert!(allocations() > probe && v.len() == 16);
    let mut d = BreakageDetector::new(WatchLimits::default());
    let before = allocations();
    let mut verdicts = 0u32;
    for i in 0..5000u32 {
        let force_n = match i % 250 {
            0..=19 => 0.0,                 // air
            120 => 40.0,                   // tool gone
            200 => 3000.0,                 // spike
            k => 800.0 + f64::from(k % 7), // steady cut
        };
        let s = BreakageSample {
            force_n,
            force_ref_n: 800.0,
            cycle_active: i % 1000 != 999,
            feed_hold_active: false,
            tool: 1 + (i / 2500) as u16,
            block: 10 * (1 + (i / 250) as u16),
            block_settled: true,
            override_pct: 60,
        };
        verdicts += u32::from(d.observe(&s).is_some());
    }
    assert_eq!(allocations(), before, "the detector allocated");
    assert!(
        verdicts >= 20,
        "{verdicts} verdicts: the drops and spikes were judged"
    );
}
