//! The store on a run's logging side: [`FleetSink`] wraps the run-log sink of the runner's
//! logger thread, so the control thread never waits on Parquet. Every record goes to the
//! run log first, then to the store's buffer; the cuts come from a [`Watch`] built like the
//! tool history's, so the store's cuts are the history's.
//!
//! A store error never stops the run log: the record is still written there, and the sink
//! returns the error so the runner counts and reports it (`log_errors`), as for the run log.

use acc_runtime::history::{Watch, WatchItem};
use acc_runtime::runner::LogSink;
use acc_runtime::RunRecord;

use crate::schema::{CutRow, PeriodRow};
use crate::store::StoreWriter;
use crate::FleetError;

/// Error of a [`FleetSink`]: the run log's or the store's.
#[derive(Debug)]
pub enum FleetSinkError<E> {
    /// The run-log sink failed.
    Log(E),
    /// The store failed (the run log has the record).
    Fleet(FleetError),
}

impl<E: std::fmt::Display> std::fmt::Display for FleetSinkError<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Log(e) => e.fmt(f),
            Self::Fleet(e) => write!(f, "fleet store: {e}"),
        }
    }
}

/// Buffers one machine's records into a [`StoreWriter`].
#[derive(Debug)]
pub struct MachineFeed {
    /// The writer.
    pub store: StoreWriter,
    /// Machine id (the `machine=` partition).
    pub machine: String,
    /// Wall-clock start of the run, µs since the Unix epoch.
    pub run_start_us: i64,
    watch: Watch,
}

impl MachineFeed {
    /// A feed of `machine`'s run that started at `run_start_us`; `watch` finds the cuts.
    pub fn new(store: StoreWriter, machine: &str, run_start_us: i64, watch: Watch) -> Self {
        Self {
            store,
            machine: machine.to_string(),
            run_start_us,
            watch,
        }
    }

    /// Buffer one record (and the cut it closes, if any).
    pub fn push(&mut self, r: &RunRecord) -> Result<(), FleetError> {
        let items = self.watch.push(r);
        self.store
            .push_period(&self.machine, PeriodRow::of(r, self.run_start_us))?;
        self.push_cuts(&items)
    }

    /// Buffer the cuts among `items`.
    pub fn push_cuts(&mut self, items: &[WatchItem]) -> Result<(), FleetError> {
        for it in items {
            if let WatchItem::Cut(c) = it {
                self.store
                    .push_cut(&self.machine, CutRow::of(c, self.run_start_us))?;
            }
        }
        Ok(())
    }

    /// The open cut, then commit everything.
    pub fn finish(&mut self) -> Result<(), FleetError> {
        let items = self.watch.finish();
        self.push_cuts(&items)?;
        self.store.commit()
    }
}

/// A [`LogSink`] writing the run log through `inner` and the store through `feed`.
#[derive(Debug)]
pub struct FleetSink<S> {
    /// The run-log sink.
    pub inner: S,
    /// The store (`None`: the run log only).
    pub feed: Option<MachineFeed>,
}

impl<S: LogSink> LogSink for FleetSink<S> {
    type Error = FleetSinkError<S::Error>;

    fn write(&mut self, rec: &RunRecord) -> Result<(), Self::Error> {
        let log = self.inner.write(rec);
        let fleet = self.feed.as_mut().map_or(Ok(()), |f| f.push(rec));
        log.map_err(FleetSinkError::Log)?;
        fleet.map_err(FleetSinkError::Fleet)
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        let log = self.inner.flush();
        let fleet = self.feed.as_mut().map_or(Ok(()), MachineFeed::finish);
        log.map_err(FleetSinkError::Log)?;
        fleet.map_err(FleetSinkError::Fleet)
    }
}
