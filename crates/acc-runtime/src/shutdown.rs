//! Process-level plumbing: the Ctrl-C / SIGTERM stop flag and the `tracing` subscriber.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use tracing_subscriber::EnvFilter;

/// Install a Ctrl-C (SIGINT) and SIGTERM handler that sets the returned flag; the runtime
/// polls it once per period and shuts down in order (see [`crate::runner`]). Can be called
/// once per process.
pub fn install_stop_flag() -> Result<Arc<AtomicBool>, ctrlc::Error> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst))?;
    Ok(stop)
}

/// The two stop flags of [`install_stop_signals`].
#[derive(Debug, Clone)]
pub struct StopSignals {
    /// Set by the first Ctrl-C / SIGTERM: stop once the cut has ended (the drain).
    pub stop: Arc<AtomicBool>,
    /// Set by a second signal: stop now (feed hold, then release).
    pub again: Arc<AtomicBool>,
}

/// Install a Ctrl-C (SIGINT) and SIGTERM handler: the first signal sets
/// [`StopSignals::stop`], every later one [`StopSignals::again`]. Can be called once per
/// process (and not together with [`install_stop_flag`]).
pub fn install_stop_signals() -> Result<StopSignals, ctrlc::Error> {
    let signals = StopSignals {
        stop: Arc::new(AtomicBool::new(false)),
        again: Arc::new(AtomicBool::new(false)),
    };
    let (stop, again) = (Arc::clone(&signals.stop), Arc::clone(&signals.again));
    ctrlc::set_handler(move || {
        if stop.swap(true, Ordering::SeqCst) {
            again.store(true, Ordering::SeqCst);
        }
    })?;
    Ok(signals)
}

/// Log output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LogFormat {
    /// Human-readable lines.
    #[default]
    Text,
    /// One JSON object per event (for log shippers).
    Json,
}

/// Install the global `tracing` subscriber on stderr. The filter comes from `ACC_LOG`
/// (or `RUST_LOG`) in `EnvFilter` syntax, e.g. `ACC_LOG=acc_runtime=debug`; `default`
/// applies when neither is set. Returns `false` if a subscriber was already installed.
pub fn init_tracing(format: LogFormat, default: &str) -> bool {
    let filter = EnvFilter::try_from_env("ACC_LOG")
        .or_else(|_| EnvFilter::try_from_default_env())
        .unwrap_or_else(|_| EnvFilter::new(default));
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr);
    match format {
        LogFormat::Text => builder.try_init().is_ok(),
        LogFormat::Json => builder.json().try_init().is_ok(),
    }
}
