//! The man in the middle on the serial line (`tests/peers/mitm_proxy.py`, an independent
//! Python program): starting and stopping it, and what it reports (its alterations, the
//! status reads it handed over, its counters) read back from its files.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{bail, Context};

use crate::child::Proc;

/// Start the man in the middle (`python3 <script> --upstream <upstream> <extra>`, see
/// `tests/peers/mitm_proxy.py`) with its output in `dir/mitm-proxy.*`; returns it and the
/// controller's side of the line (the path after `PTY ` on its first stdout line).
pub fn spawn_proxy(
    script: &Path,
    upstream: &str,
    extra: &[String],
    dir: &Path,
) -> anyhow::Result<(Proc, String)> {
    if !script.is_file() {
        bail!(
            "{}: the man-in-the-middle proxy is not there (run from the repository root, or pass its path)",
            script.display()
        );
    }
    let mut args = vec![
        script.to_string_lossy().into_owned(),
        "--upstream".to_string(),
        upstream.to_string(),
    ];
    args.extend_from_slice(extra);
    let (mut proc, line) =
        Proc::spawn_program(OsStr::new("python3"), &args, dir, "mitm-proxy", true)?;
    match line.as_deref().and_then(|l| l.strip_prefix("PTY ")) {
        Some(p) if p.starts_with('/') => Ok((proc, p.to_string())),
        _ => {
            proc.wait(Duration::from_secs(2));
            proc.drain(Duration::from_millis(200));
            bail!(
                "the proxy printed {line:?}, not `PTY <path>`: {}",
                proc.seen.join(" / ")
            )
        }
    }
}

/// Stop the proxy (SIGTERM: it writes its counters) and wait for it.
pub fn stop_proxy(proxy: &mut Proc) {
    proxy.signal("TERM");
    if proxy.wait(Duration::from_secs(5)).is_none() {
        proxy.signal("KILL");
        proxy.wait(Duration::from_secs(2));
    }
}

/// One alteration the proxy made to a reply (a line of its `--events` file).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
pub struct ProxyEvent {
    /// Monotonic time, s.
    pub t: f64,
    /// Ordinal of the FC04 request the reply answered (0-based), `None` for other replies.
    pub read_index: Option<u64>,
    /// Function code of the reply the board gave.
    pub fc: u8,
    /// `flip`, `slave`, `exception`, `bytecount`, `truncate`, `random` or `delay`.
    pub kind: String,
    /// Register (protocol address) changed: the flipped one, `SAMPLE_SEQ` for a delay.
    pub register: Option<u16>,
    /// Bit flipped.
    pub bit: Option<u8>,
    /// The changed field before (a delay: the fresh `SAMPLE_SEQ`).
    pub before: Option<i64>,
    /// The changed field after (a delay: the delivered `SAMPLE_SEQ`).
    pub after: Option<i64>,
}

/// One FC04 reply the proxy handed to the client (a line of its `--reads` file).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
pub struct ProxyRead {
    /// FC04 ordinal.
    pub i: Option<u64>,
    /// Spindle power in the delivered reply, W (`None`: it does not parse).
    pub power: Option<f64>,
    /// `OVERRIDE_APPLIED` in the delivered reply.
    pub applied: Option<u16>,
    /// The proxy altered it.
    pub altered: bool,
}

/// The proxy's counters (its `--stats` file), the fields the harness uses.
#[derive(Debug, Clone, Default, PartialEq, serde::Deserialize, serde::Serialize)]
pub struct ProxyStats {
    /// Requests from the client.
    pub requests: u64,
    /// Of which FC04 reads.
    pub fc04_reads: u64,
    /// Replies from the board.
    pub replies: u64,
    /// Requests the board did not answer.
    pub no_reply: u64,
    /// Alterations by kind (`delay` included).
    pub altered: std::collections::BTreeMap<String, u64>,
    /// Replies altered (a delayed and corrupted reply once).
    pub altered_replies: u64,
    /// Of which FC04 replies.
    pub altered_fc04_replies: u64,
    /// Times the faults were switched on (`--start on` counts one).
    pub episodes: u64,
}

impl ProxyStats {
    /// Replies corrupted (every kind but the delay).
    pub fn corrupted(&self) -> u64 {
        self.altered
            .iter()
            .filter(|(k, _)| k.as_str() != "delay")
            .map(|(_, n)| n)
            .sum()
    }
}

/// The files the man in the middle writes into a folder: its counters
/// (`proxy-stats.json`), its alterations (`proxy-events.jsonl`) and the status reads it
/// handed over (`proxy-reads.jsonl`).
#[derive(Debug, Clone)]
pub struct ProxyFiles {
    /// The counters (`--stats`).
    pub stats: PathBuf,
    /// The alterations, one JSON line each (`--events`).
    pub events: PathBuf,
    /// The FC04 replies handed to the client, one JSON line each (`--reads`).
    pub reads: PathBuf,
}

impl ProxyFiles {
    /// The three files in `dir`.
    pub fn in_dir(dir: &Path) -> Self {
        Self {
            stats: dir.join("proxy-stats.json"),
            events: dir.join("proxy-events.jsonl"),
            reads: dir.join("proxy-reads.jsonl"),
        }
    }

    /// The proxy's options that name them: `--stats … --events … --reads …`.
    pub fn args(&self) -> Vec<String> {
        let path = |p: &PathBuf| p.to_string_lossy().into_owned();
        vec![
            "--stats".into(),
            path(&self.stats),
            "--events".into(),
            path(&self.events),
            "--reads".into(),
            path(&self.reads),
        ]
    }

    /// What the proxy wrote; a file it did not write reads as nothing.
    pub fn read(&self) -> ProxyLog {
        ProxyLog {
            stats: read_proxy_stats(&self.stats).ok(),
            events: read_json_lines(&self.events).unwrap_or_default(),
            reads: read_json_lines(&self.reads).unwrap_or_default(),
        }
    }
}

/// What the man in the middle wrote: its counters, its alterations and the status reads it
/// handed over (see [`ProxyFiles`]).
#[derive(Debug, Clone, Default)]
pub struct ProxyLog {
    /// The counters (`None`: it wrote none).
    pub stats: Option<ProxyStats>,
    /// Its alterations of replies.
    pub events: Vec<ProxyEvent>,
    /// The FC04 replies it handed over.
    pub reads: Vec<ProxyRead>,
}

/// Read a file of JSON lines.
pub fn read_json_lines<T: serde::de::DeserializeOwned>(path: &Path) -> anyhow::Result<Vec<T>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?;
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .enumerate()
        .map(|(i, l)| {
            serde_json::from_str(l).with_context(|| format!("{} line {}", path.display(), i + 1))
        })
        .collect()
}

/// Read the proxy's counters.
pub fn read_proxy_stats(path: &Path) -> anyhow::Result<ProxyStats> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proxy_records_parse() {
        let dir = tempfile::tempdir().expect("tmp");
        let ev = dir.path().join("e.jsonl");
        std::fs::write(
            &ev,
            "{\"t\": 1.5, \"read_index\": 3, \"fc\": 4, \"kind\": \"flip\", \"register\": 2, \"bit\": 6, \"before\": 100, \"after\": 36}\n\
             {\"t\": 1.6, \"read_index\": null, \"fc\": 16, \"kind\": \"slave\", \"register\": null, \"bit\": null, \"before\": 1, \"after\": 9}\n",
        )
        .expect("write");
        let events: Vec<ProxyEvent> = read_json_lines(&ev).expect("events");
        assert_eq!(events.len(), 2);
        assert_eq!((events[0].register, events[0].after), (Some(2), Some(36)));
        assert_eq!(events[1].read_index, None);
        let st = dir.path().join("s.json");
        std::fs::write(
            &st,
            r#"{"requests": 10, "fc04_reads": 5, "replies": 10, "no_reply": 0, "altered": {"flip": 2, "delay": 3}, "altered_replies": 5, "altered_fc04_replies": 4, "episodes": 1, "on": false}"#,
        )
        .expect("write");
        let s = read_proxy_stats(&st).expect("stats");
        assert_eq!((s.corrupted(), s.episodes), (2, 1));
    }
}
