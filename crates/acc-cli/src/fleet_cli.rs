//! `--fleet DIR` and `--machine ID` of `acc sim` and `acc run`: the run's period and cut
//! records also go to the fleet store (Parquet, `docs/fleet.md`).

use std::path::PathBuf;

use acc_fleet::sink::MachineFeed;
use acc_fleet::store::check_machine_id;
use acc_fleet::StoreWriter;
use acc_runtime::history::{Watch, WatchItem};
use acc_runtime::RunRecord;
use anyhow::Context;

/// The fleet-store options.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct FleetArgs {
    /// Also write the run's period and cut records to this fleet store (Parquet,
    /// partitioned `machine=<id>/date=<YYYY-MM-DD>/`; over `[fleet] dir`).
    #[arg(long, value_name = "DIR")]
    pub fleet: Option<PathBuf>,
    /// Machine id in the fleet store (default: this host's name; over `[fleet] machine`).
    #[arg(long, value_name = "ID")]
    pub machine: Option<String>,
}

/// This host's name (`/etc/hostname`, else `HOSTNAME`, else `local`).
pub fn host_name() -> String {
    std::fs::read_to_string("/etc/hostname")
        .ok()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "local".into())
}

pub use acc_fleet::schema::now_us;

/// A store opened for one run: the machine id checked, the file tag unique to this process.
pub struct OpenStore {
    /// The writer.
    pub store: StoreWriter,
    /// Machine id.
    pub machine: String,
    /// Run start, µs since the Unix epoch.
    pub run_start_us: i64,
}

impl FleetArgs {
    /// Open the store when `--fleet` is given (`None`: no store).
    pub fn open(&self, run_start_us: i64) -> anyhow::Result<Option<OpenStore>> {
        let Some(dir) = &self.fleet else {
            return Ok(None);
        };
        let machine = self.machine.clone().unwrap_or_else(host_name);
        check_machine_id(&machine).context("--machine")?;
        let tag = format!("{run_start_us}-{}", std::process::id());
        let store =
            StoreWriter::new(dir, &tag).with_context(|| format!("--fleet {}", dir.display()))?;
        Ok(Some(OpenStore {
            store,
            machine,
            run_start_us,
        }))
    }
}

impl OpenStore {
    /// A feed for the runner's logger thread ([`acc_fleet::FleetSink`]).
    pub fn feed(self, watch: Watch) -> MachineFeed {
        MachineFeed::new(self.store, &self.machine, self.run_start_us, watch)
    }

    /// Write a whole run: its rows and the cuts among the watch's `items`; prints what was
    /// committed.
    pub fn write_run(mut self, rows: &[RunRecord], items: &[WatchItem]) -> anyhow::Result<()> {
        for r in rows {
            self.store.push_period(
                &self.machine,
                acc_fleet::PeriodRow::of(r, self.run_start_us),
            )?;
        }
        for it in items {
            if let WatchItem::Cut(c) = it {
                self.store
                    .push_cut(&self.machine, acc_fleet::CutRow::of(c, self.run_start_us))?;
            }
        }
        let root = self.store.root().to_path_buf();
        let done = self.store.finish()?;
        println!(
            "fleet store: {} periods, {} cuts of machine {} in {} files under {}",
            done.periods,
            done.cuts,
            self.machine,
            done.files,
            root.display()
        );
        Ok(())
    }
}
