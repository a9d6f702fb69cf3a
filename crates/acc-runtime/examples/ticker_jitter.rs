//! Loop-timing measurement: the real ticker (SystemClock, absolute deadlines) for N periods
//! at period T, with one control decision of work per period (the fault policy and a law
//! against the in-memory board), reporting period jitter p50 / p99 / max and overruns.
//!
//! ```text
//! cargo run --release -p acc-runtime --example ticker_jitter -- 1000 36000
//! #                                                              T[µs] periods
//! ```
//! 36 000 periods at T = 1 ms is 36 s of wall time and as many periods as 1 h at T = 0.1 s
//! (the production T): the ticker's behaviour does not depend on T beyond the sleep
//! granularity, and a shorter T only makes overruns more likely.

use std::time::Duration;

use acc_runtime::policy::{FaultPolicy, PolicyConfig};
use acc_runtime::testing::{LinearPowerForce, ScriptedBoard, ScriptedLaw};
use acc_runtime::{ControlLoop, SystemClock, Ticker};

fn main() {
    let args: Vec<u64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let period_us = args.first().copied().unwrap_or(1000).max(1);
    let periods = args.get(1).copied().unwrap_or(36_000).max(1);
    let period = Duration::from_micros(period_us);
    let mut board = ScriptedBoard::new();
    let mut lp = ControlLoop::new(
        FaultPolicy::new(PolicyConfig::default()),
        ScriptedLaw::new([90, 80, 70]),
        LinearPowerForce { n_per_w: 0.5 },
        period.as_secs_f64(),
    );
    let mut ticker = match Ticker::new(SystemClock::new(), period) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    for k in 0..periods {
        let tick = ticker.wait();
        board.board.push_power_sample(1500);
        board.now_ms = tick.deadline.as_millis() as u64;
        lp.cycle(&mut board, k as f64 * period.as_secs_f64());
    }
    let s = ticker.stats();
    println!(
        "T = {} us, {} periods ({:.1} s): jitter p50 = {} us, p99 = {} us, max = {} us, mean = {} us; overruns = {} ({:.3} %), skipped deadlines = {}",
        period_us,
        s.ticks,
        s.ticks as f64 * period.as_secs_f64(),
        s.jitter.quantile(0.5).as_micros(),
        s.jitter.quantile(0.99).as_micros(),
        s.jitter.max().as_micros(),
        s.jitter.mean().as_micros(),
        s.overruns,
        100.0 * s.overruns as f64 / s.ticks.max(1) as f64,
        s.skipped
    );
}
