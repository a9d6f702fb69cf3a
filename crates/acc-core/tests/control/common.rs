//! Shared test plant: the paper's linearised process (eq. 6), `Fc(i) = Km·Kc(i)·U_applied`,
//! where `U_applied` is the feed the previous command gave.
#![allow(dead_code)]

use acc_core::{Controller, FeedOverride, Measurement, OverrideLaw, StepOutput};

/// Programmed feed of the test NC block, mm/min (paper: nominal 200).
pub const PROGRAMMED: f64 = 200.0;

/// Closed-loop run: `kc(i)` is the true process gain at period `i` (0 = air cut);
/// `unquantized` feeds the continuous command `U(i)` back instead of the board's quantized
/// override (to check pole placement without the quantizer). Returns the outputs and the
/// force of each period.
pub fn run(
    ctl: &mut Controller,
    start: FeedOverride,
    n: usize,
    kc: impl Fn(usize) -> f64,
    unquantized: bool,
) -> Vec<(StepOutput, f64)> {
    ctl.engage(start);
    let km = ctl.config().km;
    let mut feed = start.feed_mm_min(PROGRAMMED);
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let force = km * kc(i) * feed;
        let m = Measurement {
            force_n: force,
            feed_mm_min: feed,
            programmed_feed_mm_min: PROGRAMMED,
            valid: true,
        };
        let o = ctl.step(&m);
        feed = if unquantized {
            o.trace.feed_cmd_mm_min
        } else {
            o.command.feed_mm_min(PROGRAMMED)
        };
        out.push((o, force));
    }
    out
}
