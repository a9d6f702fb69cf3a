//! A recorded (or live, piped) stream of spindle samples as a force source.
//!
//! A DAQ program writes one frame per sample instant: `i_u, i_v, v_uw, v_vw` (A, A, V, V).
//! Formats ([`SampleFormat`]):
//!
//! * `csv`: one frame per line, four comma-separated numbers; an optional header line
//!   `i_u,i_v,v_uw,v_vw`;
//! * `f32le` / `f64le`: raw little-endian IEEE floats, frames of 4 values back to back
//!   (16 or 32 bytes per frame), no header.
//!
//! The stream carries no clock: the source takes its sample rate from the configuration
//! and reads `round(T · rate)` frames per period. Errors name the line (CSV) or the byte
//! offset (binary). After any error — including the end of the stream, or a stream that
//! ends in the middle of a period — every further period is [`ForceSample::INVALID`].

use std::fs::File;
use std::io::{BufRead, BufReader, ErrorKind, Read};
use std::path::Path;

use acc_core::spindle_force::{SpindleError, SpindleEstimator, SpindleInput, SpindleSource};
use acc_core::RangeError;
use acc_core::{ForceSample, ForceSource, PeriodInput, PhaseBlock};

/// Layout of the sample stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleFormat {
    /// Text, one `i_u,i_v,v_uw,v_vw` frame per line.
    Csv,
    /// Raw little-endian `f32`, 4 per frame.
    F32Le,
    /// Raw little-endian `f64`, 4 per frame.
    F64Le,
}

impl SampleFormat {
    /// Parse `csv`, `f32le`, `f64le`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "csv" => Some(Self::Csv),
            "f32le" | "f32" => Some(Self::F32Le),
            "f64le" | "f64" => Some(Self::F64Le),
            _ => None,
        }
    }

    /// Guess from a file extension (`.csv`, `.f32`, `.f64`).
    pub fn from_path(path: &Path) -> Option<Self> {
        Self::parse(path.extension()?.to_str()?)
    }
}

/// Where in the stream something happened.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Position {
    /// 1-based line of a CSV stream.
    Line(u64),
    /// Byte offset of a binary stream.
    Byte(u64),
}

impl std::fmt::Display for Position {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Position::Line(l) => write!(f, "line {l}"),
            Position::Byte(b) => write!(f, "byte offset {b}"),
        }
    }
}

/// Errors of a sample stream; each names its position.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StreamError {
    /// The file could not be opened.
    #[error("{}: cannot open: {reason}", path.display())]
    Open {
        /// File path.
        path: std::path::PathBuf,
        /// OS error text.
        reason: String,
    },
    /// Reading failed.
    #[error("{at}: read error: {reason}")]
    Io {
        /// Position.
        at: Position,
        /// OS error text.
        reason: String,
    },
    /// A CSV field is not a number.
    #[error("{at}: field {field} (`{channel}`) is not a number: `{text}`")]
    Parse {
        /// Position.
        at: Position,
        /// 1-based field number.
        field: usize,
        /// Channel name.
        channel: &'static str,
        /// Offending text.
        text: String,
    },
    /// A CSV line without exactly 4 fields.
    #[error("{at}: {found} fields, expected 4 (i_u,i_v,v_uw,v_vw)")]
    ChannelCount {
        /// Position.
        at: Position,
        /// Fields found.
        found: usize,
    },
    /// A NaN or infinite sample.
    #[error("{at}: non-finite sample in `{channel}`")]
    NonFinite {
        /// Position.
        at: Position,
        /// Channel name.
        channel: &'static str,
    },
    /// A binary stream ending inside a frame.
    #[error("{at}: stream ends inside a frame ({bytes} of {frame} bytes)")]
    PartialFrame {
        /// Position of the frame start.
        at: Position,
        /// Bytes present.
        bytes: usize,
        /// Frame size.
        frame: usize,
    },
    /// The stream ended inside a control period.
    #[error("{at}: stream ends inside a period ({got} of {needed} samples)")]
    Truncated {
        /// Position of the end.
        at: Position,
        /// Frames read for the period.
        got: usize,
        /// Frames the period needs.
        needed: usize,
    },
    /// The stream ended at a period boundary.
    #[error("{at}: end of stream")]
    End {
        /// Position of the end.
        at: Position,
    },
}

const CHANNELS: [&str; 4] = ["i_u", "i_v", "v_uw", "v_vw"];

/// Reader of frames from any byte stream (file, pipe, stdin).
pub struct SampleStream<R: Read> {
    format: SampleFormat,
    csv: Option<csv::Reader<R>>,
    raw: Option<R>,
    record: csv::StringRecord,
    offset: u64,
    line: u64,
}

impl<R: Read> std::fmt::Debug for SampleStream<R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SampleStream")
            .field("format", &self.format)
            .field("offset", &self.offset)
            .field("line", &self.line)
            .finish()
    }
}

impl SampleStream<Box<dyn BufRead + Send>> {
    /// Open a file, or standard input for `-`.
    pub fn open(path: &Path, format: SampleFormat) -> Result<Self, StreamError> {
        let reader: Box<dyn BufRead + Send> = if path.as_os_str() == "-" {
            Box::new(BufReader::new(std::io::stdin()))
        } else {
            let f = File::open(path).map_err(|e| StreamError::Open {
                path: path.to_path_buf(),
                reason: e.to_string(),
            })?;
            Box::new(BufReader::new(f))
        };
        Ok(Self::new(reader, format))
    }
}

impl<R: Read> SampleStream<R> {
    /// Wrap a reader.
    pub fn new(reader: R, format: SampleFormat) -> Self {
        let (csv, raw) = match format {
            SampleFormat::Csv => (
                Some(
                    csv::ReaderBuilder::new()
                        .has_headers(false)
                        .flexible(true)
                        .trim(csv::Trim::All)
                        .from_reader(reader),
                ),
                None,
            ),
            _ => (None, Some(reader)),
        };
        Self {
            format,
            csv,
            raw,
            record: csv::StringRecord::new(),
            offset: 0,
            line: 0,
        }
    }

    fn position(&self) -> Position {
        match self.format {
            SampleFormat::Csv => Position::Line(self.line),
            _ => Position::Byte(self.offset),
        }
    }

    /// Read one frame; `Ok(None)` at a clean end of stream.
    pub fn next_frame(&mut self) -> Result<Option<[f64; 4]>, StreamError> {
        let frame = match self.format {
            SampleFormat::Csv => self.next_csv()?,
            SampleFormat::F32Le => self.next_raw::<4>()?,
            SampleFormat::F64Le => self.next_raw::<8>()?,
        };
        if let Some(f) = frame {
            if let Some(k) = f.iter().position(|v| !v.is_finite()) {
                return Err(StreamError::NonFinite {
                    at: self.position(),
                    channel: CHANNELS[k],
                });
            }
        }
        Ok(frame)
    }

    fn next_csv(&mut self) -> Result<Option<[f64; 4]>, StreamError> {
        let Some(rd) = self.csv.as_mut() else {
            return Ok(None);
        };
        loop {
            let more = rd
                .read_record(&mut self.record)
                .map_err(|e| StreamError::Io {
                    at: Position::Line(self.line + 1),
                    reason: e.to_string(),
                })?;
            if !more {
                return Ok(None);
            }
            self.line = self.record.position().map_or(self.line + 1, |p| p.line());
            if self.record.len() == 1 && self.record[0].is_empty() {
                continue;
            }
            if self.record.len() != 4 {
                return Err(StreamError::ChannelCount {
                    at: Position::Line(self.line),
                    found: self.record.len(),
                });
            }
            if self.line == 1 && self.record[0].eq_ignore_ascii_case("i_u") {
                continue;
            }
            let mut out = [0.0; 4];
            for (k, o) in out.iter_mut().enumerate() {
                let text = &self.record[k];
                *o = text.parse::<f64>().map_err(|_| StreamError::Parse {
                    at: Position::Line(self.line),
                    field: k + 1,
                    channel: CHANNELS[k],
                    text: text.to_string(),
                })?;
            }
            return Ok(Some(out));
        }
    }

    fn next_raw<const W: usize>(&mut self) -> Result<Option<[f64; 4]>, StreamError> {
        let Some(rd) = self.raw.as_mut() else {
            return Ok(None);
        };
        let frame = 4 * W;
        let mut buf = [0u8; 32];
        let mut got = 0;
        while got < frame {
            match rd.read(&mut buf[got..frame]) {
                Ok(0) => break,
                Ok(k) => got += k,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => {
                    return Err(StreamError::Io {
                        at: Position::Byte(self.offset + got as u64),
                        reason: e.to_string(),
                    })
                }
            }
        }
        if got == 0 {
            return Ok(None);
        }
        if got < frame {
            return Err(StreamError::PartialFrame {
                at: Position::Byte(self.offset),
                bytes: got,
                frame,
            });
        }
        self.offset += frame as u64;
        let mut out = [0.0; 4];
        for (k, o) in out.iter_mut().enumerate() {
            let b = &buf[k * W..(k + 1) * W];
            *o = if W == 4 {
                f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            } else {
                f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]])
            };
        }
        Ok(Some(out))
    }
}

/// Per-channel buffers of one period (allocated once).
#[derive(Debug, Default, Clone)]
struct Buffers {
    ch: [Vec<f64>; 4],
}

/// A [`ForceSource`] reading a sample stream: each period it reads `round(T·rate)` frames
/// and hands them, as a three-phase block, to a [`SpindleSource`].
#[derive(Debug)]
pub struct StreamForceSource<R: Read> {
    stream: SampleStream<R>,
    inner: SpindleSource,
    sample_rate_hz: f64,
    buf: Buffers,
    error: Option<StreamError>,
}

impl<R: Read> StreamForceSource<R> {
    /// A source reading `stream` sampled at `sample_rate_hz` through `est`.
    pub fn new(
        stream: SampleStream<R>,
        sample_rate_hz: f64,
        est: SpindleEstimator,
    ) -> Result<Self, SpindleError> {
        if !(sample_rate_hz.is_finite() && (1.0..=1e7).contains(&sample_rate_hz)) {
            return Err(SpindleError::OutOfRange(RangeError::new(
                "sample_rate_hz",
                sample_rate_hz,
                "1 ..= 1e7",
            )));
        }
        Ok(Self {
            stream,
            inner: SpindleSource::new(SpindleInput::Phases, est)?,
            sample_rate_hz,
            buf: Buffers::default(),
            error: None,
        })
    }

    /// The error that stopped the stream, if any (end of stream included).
    pub fn error(&self) -> Option<&StreamError> {
        self.error.as_ref()
    }

    /// The inner source (last estimate, estimator).
    pub fn inner(&self) -> &SpindleSource {
        &self.inner
    }

    fn fill(&mut self, needed: usize) -> Result<(), StreamError> {
        for c in &mut self.buf.ch {
            c.clear();
            c.reserve(needed);
        }
        for got in 0..needed {
            match self.stream.next_frame()? {
                Some(f) => {
                    for (c, v) in self.buf.ch.iter_mut().zip(f) {
                        c.push(v);
                    }
                }
                None if got == 0 => {
                    return Err(StreamError::End {
                        at: self.stream.position(),
                    })
                }
                None => {
                    return Err(StreamError::Truncated {
                        at: self.stream.position(),
                        got,
                        needed,
                    })
                }
            }
        }
        Ok(())
    }
}

impl<R: Read + Send> ForceSource for StreamForceSource<R> {
    fn name(&self) -> &str {
        "spindle-stream"
    }

    fn estimate(&mut self, input: &PeriodInput<'_>) -> ForceSample {
        if self.error.is_some() {
            return ForceSample::INVALID;
        }
        let needed = (input.period_s * self.sample_rate_hz).round();
        if !(1.0..=1e8).contains(&needed) {
            return ForceSample::INVALID;
        }
        if let Err(e) = self.fill(needed as usize) {
            self.error = Some(e);
            return ForceSample::INVALID;
        }
        let [iu, iv, vuw, vvw] = &self.buf.ch;
        let block = PhaseBlock {
            sample_rate_hz: self.sample_rate_hz,
            i_u: iu,
            i_v: iv,
            v_uw: vuw,
            v_vw: vvw,
        };
        let period = PeriodInput {
            phases: Some(block),
            ..*input
        };
        self.inner.estimate(&period)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_frames_header_and_errors_name_the_line() {
        let text = "i_u,i_v,v_uw,v_vw\n1,2,3,4\n\n5,6,7,8\n1,2,x,4\n";
        let mut s = SampleStream::new(text.as_bytes(), SampleFormat::Csv);
        assert_eq!(s.next_frame().unwrap(), Some([1.0, 2.0, 3.0, 4.0]));
        assert_eq!(s.next_frame().unwrap(), Some([5.0, 6.0, 7.0, 8.0]));
        let e = s.next_frame().unwrap_err();
        assert_eq!(
            e.to_string(),
            "line 5: field 3 (`v_uw`) is not a number: `x`"
        );
        let mut s = SampleStream::new("1,2,3\n".as_bytes(), SampleFormat::Csv);
        assert_eq!(
            s.next_frame().unwrap_err().to_string(),
            "line 1: 3 fields, expected 4 (i_u,i_v,v_uw,v_vw)"
        );
        let mut s = SampleStream::new("1,2,3,NaN\n".as_bytes(), SampleFormat::Csv);
        assert!(matches!(
            s.next_frame(),
            Err(StreamError::NonFinite {
                channel: "v_vw",
                ..
            })
        ));
    }

    #[test]
    fn binary_frames_and_partial_frame_offset() {
        let mut bytes = vec![];
        for v in [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        bytes.extend_from_slice(&[0u8; 6]);
        let mut s = SampleStream::new(bytes.as_slice(), SampleFormat::F32Le);
        assert_eq!(s.next_frame().unwrap(), Some([1.0, 2.0, 3.0, 4.0]));
        assert_eq!(s.next_frame().unwrap(), Some([5.0, 6.0, 7.0, 8.0]));
        assert_eq!(
            s.next_frame().unwrap_err().to_string(),
            "byte offset 32: stream ends inside a frame (6 of 16 bytes)"
        );
        let mut bytes = vec![];
        for v in [1.0f64, -2.5, 3.0, 4.0] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        let mut s = SampleStream::new(bytes.as_slice(), SampleFormat::F64Le);
        assert_eq!(s.next_frame().unwrap(), Some([1.0, -2.5, 3.0, 4.0]));
        assert_eq!(s.next_frame().unwrap(), None);
    }
}
