//! `acc collect --mqtt mqtt://host:port/PREFIX --out DIR`: the fleet store written from the
//! machines' MQTT messages (`PREFIX/<machine>/period` and `PREFIX/<machine>/cut`).

use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::Duration;

use acc_fleet::collect::{CollectOptions, CollectStats};
use acc_runtime::config::MqttSettings;
use acc_runtime::Clock;
use anyhow::Context;

/// `acc collect` arguments.
#[derive(clap::Args, Debug)]
pub struct CollectArgs {
    /// The broker and topic prefix, `mqtt://host[:port]/PREFIX`: subscribes to
    /// `PREFIX/+/period` and `PREFIX/+/cut`, `+` being the machine id (a machine publishes
    /// with `--mqtt mqtt://host:port/PREFIX/MACHINE`).
    #[arg(long, value_name = "URL", value_parser = MqttSettings::from_url)]
    pub mqtt: MqttSettings,
    /// The fleet store to write (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Client id of the collector's persistent session (the broker keeps the cuts it has
    /// not acknowledged for this id across a restart).
    #[arg(long, value_name = "ID", default_value = "acc-collect")]
    pub client_id: String,
    /// Commit the buffered rows to Parquet at least this often, s (0.1 ..= 3600).
    #[arg(long, value_name = "S", default_value_t = 5.0)]
    pub commit_s: f64,
    /// Stop after this long, s (default: until Ctrl-C or SIGTERM).
    #[arg(long, value_name = "S")]
    pub duration_s: Option<f64>,
}

/// Run `acc collect`.
pub fn run(args: &CollectArgs) -> anyhow::Result<()> {
    if !(args.commit_s.is_finite() && (0.1..=3600.0).contains(&args.commit_s)) {
        anyhow::bail!("--commit-s {}: allowed 0.1 ..= 3600 s", args.commit_s);
    }
    if let Some(d) = args.duration_s {
        if !(d.is_finite() && d > 0.0) {
            anyhow::bail!("--duration-s {d}: allowed > 0 s");
        }
    }
    let opts = CollectOptions {
        host: args.mqtt.host.clone(),
        port: args.mqtt.port,
        prefix: args.mqtt.prefix.clone(),
        client_id: args.client_id.clone(),
        out: args.out.clone(),
        commit_every: Duration::from_secs_f64(args.commit_s),
        max_unacked: 16,
    };
    acc_runtime::shutdown::init_tracing(acc_runtime::shutdown::LogFormat::Text, "info");
    let stop =
        acc_runtime::shutdown::install_stop_flag().context("installing the Ctrl-C handler")?;
    if let Some(d) = args.duration_s {
        let stop = stop.clone();
        std::thread::spawn(move || {
            acc_runtime::SystemClock::new().sleep_until(Duration::from_secs_f64(d));
            stop.store(true, Ordering::SeqCst);
        });
    }
    println!(
        "collecting {}/+/period and {}/+/cut from {}:{} into {}",
        opts.prefix,
        opts.prefix,
        opts.host,
        opts.port,
        opts.out.display()
    );
    let stats = CollectStats::default();
    let result = acc_fleet::collect::run(&opts, &stop, &stats);
    println!(
        "collected: {} periods, {} cuts ({} repeated cuts not stored twice, {} messages rejected); {} rows committed; {} connections, {} connection errors",
        stats.periods.load(Ordering::SeqCst),
        stats.cuts.load(Ordering::SeqCst),
        stats.duplicates.load(Ordering::SeqCst),
        stats.rejected.load(Ordering::SeqCst),
        stats.committed.load(Ordering::SeqCst),
        stats.connects.load(Ordering::SeqCst),
        stats.conn_errors.load(Ordering::SeqCst),
    );
    let lag = stats
        .lag
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .clone();
    if let (Some(p50), Some(p99)) = (lag.quantile_ms(0.5), lag.quantile_ms(0.99)) {
        println!(
            "lag from publish to commit: p50 {p50} ms, p99 {p99} ms, max {} ms ({} periods)",
            lag.max_ms(),
            lag.len()
        );
    }
    result.with_context(|| format!("--out {}", args.out.display()))
}
