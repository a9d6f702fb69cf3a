//! The logger thread: it owns the [`LogSink`], writes and flushes each record the control
//! thread hands it, and at the end drains the queue and flushes.

use crossbeam_channel::Receiver;

use crate::record::RunRecord;

/// Where the logger thread puts the records (the CLI writes the run-log CSV).
pub trait LogSink {
    /// Error of the sink.
    type Error: std::fmt::Display;
    /// Write one record (and flush it, for a run log that survives a crash).
    fn write(&mut self, rec: &RunRecord) -> Result<(), Self::Error>;
    /// Flush everything (called once at the end).
    fn flush(&mut self) -> Result<(), Self::Error>;
}

/// A sink that keeps the records in memory (tests).
#[derive(Debug, Default, Clone)]
pub struct VecSink(pub Vec<RunRecord>);

impl LogSink for VecSink {
    type Error = std::convert::Infallible;
    fn write(&mut self, rec: &RunRecord) -> Result<(), Self::Error> {
        self.0.push(rec.clone());
        Ok(())
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// What the logger thread reports at the end: the sink's errors (records lost).
#[derive(Debug, Clone, Default)]
pub(super) struct Written {
    /// Errors the sink reported.
    pub errors: u64,
    /// The first of them.
    pub first_error: Option<String>,
}

/// The logger thread's body: write every record of `records` to `sink` until the control
/// thread closes the queue, then flush; the first error is traced, all are counted.
pub(super) fn write_all<S: LogSink>(sink: &mut S, records: Receiver<RunRecord>) -> Written {
    let _span = tracing::info_span!("logger").entered();
    let mut w = Written::default();
    for rec in records.iter() {
        if let Err(e) = sink.write(&rec) {
            w.errors += 1;
            if w.first_error.is_none() {
                tracing::error!(error = %e, "run log write failed");
                w.first_error = Some(e.to_string());
            }
        }
    }
    if let Err(e) = sink.flush() {
        w.errors += 1;
        w.first_error.get_or_insert(e.to_string());
    }
    w
}
