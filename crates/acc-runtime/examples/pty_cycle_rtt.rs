//! Round-trip time of one controller cycle over a pty (read status FC04 + write override
//! and heartbeat FC16) with the production RTU client against the board emulator, whose
//! replies are paced at the wire time of the baud rate (a pty itself moves bytes
//! instantly; requests are not paced, so the figure is slightly optimistic by the request's
//! wire time, 8 + 13 bytes).
//!
//! ```text
//! cargo run --release -p acc-runtime --example pty_cycle_rtt -- 19200 115200
//! ```

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use acc_pmc::emu::{BoardLogic, Paced, PtyBoard};
use acc_pmc::rtu::{RtuBoard, RtuLinkConfig};
use acc_pmc::Board;
use acc_runtime::LatencyStats;

fn main() {
    let bauds: Vec<u32> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let bauds = if bauds.is_empty() {
        vec![19_200, 115_200]
    } else {
        bauds
    };
    for baud in bauds {
        let mut logic = BoardLogic::default();
        logic.set_acc_switch(true);
        let shared = Arc::new(Mutex::new(logic));
        let mut pty = match PtyBoard::spawn_with(shared, 1, baud, move |p| Paced::new(p, baud, 10))
        {
            Ok(p) => p,
            Err(e) => {
                eprintln!("pty: {e}");
                std::process::exit(1);
            }
        };
        let Some(port) = pty.take_client_port() else {
            eprintln!("no client port");
            std::process::exit(1);
        };
        let cfg = RtuLinkConfig {
            timeout: Duration::from_millis(200),
            budget: Duration::from_millis(400),
            ..RtuLinkConfig::default()
        };
        let mut link = RtuBoard::new(port, cfg);
        let mut rtt = LatencyStats::new();
        let mut errors = 0u32;
        for hb in 0..500u16 {
            let t0 = Instant::now();
            let ok = link.read_status().is_ok() && link.write_override(100, hb).is_ok();
            if ok {
                rtt.record(t0.elapsed());
            } else {
                errors += 1;
            }
        }
        println!(
            "{baud} baud (8N1 paced replies): cycle RTT p50 = {:.2} ms, p99 = {:.2} ms, max = {:.2} ms over {} cycles, {errors} errors",
            rtt.quantile(0.5).as_secs_f64() * 1e3,
            rtt.quantile(0.99).as_secs_f64() * 1e3,
            rtt.max().as_secs_f64() * 1e3,
            rtt.count()
        );
    }
}
