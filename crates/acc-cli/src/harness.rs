//! Process harness shared by `acc fault-matrix` and `acc soak`: this same `acc` binary started
//! as `acc board-sim` / `acc run` children, their stderr collected line by line (and copied
//! to a file), signals sent with kill(1), run logs read back; and the man in the middle on
//! the serial line (`tests/peers/mitm_proxy.py`, an independent Python program) with what
//! it reports (its events, the reads it handed over, its counters) matched against `acc
//! run`'s log.

use std::collections::HashMap;
use std::ffi::OsStr;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use acc_runtime::record::{read_run_log, RunRecord};
use anyhow::{bail, Context};

/// A child `acc` process with its stderr lines collected on a thread.
pub struct Proc {
    /// The child process.
    pub child: Child,
    lines: mpsc::Receiver<String>,
    /// stderr lines seen so far.
    pub seen: Vec<String>,
}

impl Proc {
    /// Start `acc <args>` with stdout/stderr copied into `dir/<name>.stdout|.stderr`; for
    /// `name == "board-sim"` the first stdout line (the pty path) is returned.
    pub fn spawn(
        args: &[String],
        dir: &Path,
        name: &str,
    ) -> anyhow::Result<(Proc, Option<String>)> {
        let exe = std::env::current_exe().context("path of the acc binary")?;
        Self::spawn_program(exe.as_os_str(), args, dir, name, name == "board-sim")
    }

    /// Start `program <args>` with stdout/stderr copied into `dir/<name>.stdout|.stderr`;
    /// with `first_line` the first stdout line is returned (and stdout is not copied).
    pub fn spawn_program(
        program: &OsStr,
        args: &[String],
        dir: &Path,
        name: &str,
        first_line: bool,
    ) -> anyhow::Result<(Proc, Option<String>)> {
        let stdout_file = std::fs::File::create(dir.join(format!("{name}.stdout")))?;
        let mut cmd = Command::new(program);
        cmd.args(args).stderr(Stdio::piped());
        if first_line {
            cmd.stdout(Stdio::piped());
        } else {
            cmd.stdout(stdout_file);
        }
        let mut child = cmd
            .spawn()
            .with_context(|| format!("starting {} ({name})", program.to_string_lossy()))?;
        let (tx, rx) = mpsc::channel();
        let err = child.stderr.take().context("stderr piped")?;
        let mut copy = std::fs::File::create(dir.join(format!("{name}.stderr")))?;
        std::thread::spawn(move || {
            for line in BufReader::new(err).lines().map_while(Result::ok) {
                let _ = writeln!(copy, "{line}");
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let path = if first_line {
            let out = child.stdout.take().context("stdout piped")?;
            let mut line = String::new();
            BufReader::new(out).read_line(&mut line)?;
            Some(line.trim().to_string())
        } else {
            None
        };
        Ok((
            Proc {
                child,
                lines: rx,
                seen: Vec::new(),
            },
            path,
        ))
    }

    /// Wait (at most `timeout`) for a stderr line containing `needle`; returns it.
    pub fn wait_for(&mut self, needle: &str, timeout: Duration) -> Option<String> {
        let end = Instant::now() + timeout;
        loop {
            if let Some(l) = self.seen.iter().find(|l| l.contains(needle)) {
                return Some(l.clone());
            }
            let left = end.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return None;
            }
            match self.lines.recv_timeout(left.min(Duration::from_millis(50))) {
                Ok(l) => self.seen.push(l),
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    return self.seen.iter().find(|l| l.contains(needle)).cloned()
                }
            }
        }
    }

    /// Collect the stderr lines that arrived so far (waiting `grace` for late ones).
    pub fn drain(&mut self, grace: Duration) {
        let end = Instant::now() + grace;
        while let Ok(l) = self
            .lines
            .recv_timeout(end.saturating_duration_since(Instant::now()))
        {
            self.seen.push(l);
        }
    }

    /// Send a signal by name (`INT`, `TERM`, `KILL`, `STOP`, `CONT`) with kill(1).
    pub fn signal(&self, sig: &str) {
        let _ = Command::new("kill")
            .args(["-s", sig, &self.child.id().to_string()])
            .status();
    }

    /// The exit of a process still running at the end of its window: Ctrl-C, then at most
    /// 20 s of wall time, as the tables show it (`running; stopped by the harness (<exit>)`,
    /// or `hung (killed by the harness)`: dropping the process kills it).
    pub fn stop_running(&mut self) -> String {
        self.signal("INT");
        match self.wait(Duration::from_secs(20)) {
            Some(st) => format!("running; stopped by the harness ({})", describe(st)),
            None => "hung (killed by the harness)".into(),
        }
    }

    /// Wait for the exit at most `timeout`; `None` if still running.
    pub fn wait(&mut self, timeout: Duration) -> Option<std::process::ExitStatus> {
        let end = Instant::now() + timeout;
        loop {
            if let Ok(Some(st)) = self.child.try_wait() {
                return Some(st);
            }
            if Instant::now() > end {
                return None;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// An exit status as the tables show it: the code, or the signal.
pub fn describe(st: std::process::ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match (st.code(), st.signal()) {
        (Some(c), _) => c.to_string(),
        (None, Some(9)) => "killed (SIGKILL)".into(),
        (None, Some(s)) => format!("signal {s}"),
        (None, None) => "?".into(),
    }
}

/// Read a run log (any schema version), naming the file in errors.
pub fn read(path: &Path) -> anyhow::Result<Vec<RunRecord>> {
    let file = std::fs::File::open(path).with_context(|| format!("{}", path.display()))?;
    read_run_log(file).with_context(|| format!("{}", path.display()))
}

/// Resident set size and thread count of a process (`/proc/PID/status`): (KiB, threads).
pub fn rss_kib_and_threads(pid: u32) -> Option<(u64, u64)> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let field = |key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(key))
            .and_then(|v| v.split_whitespace().next())
            .and_then(|v| v.parse::<u64>().ok())
    };
    Some((field("VmRSS:")?, field("Threads:")?))
}

/// The never-raise invariant on an `acc run` log: the periods in which ACC drove the
/// override with an unusable force sample (or a link fault) and its command rose above the
/// one before. Must be 0.
pub fn fault_periods_raising(rows: &[RunRecord]) -> usize {
    let mut raised = 0;
    let mut prev: Option<u16> = None;
    for x in rows {
        if x.state != "active" {
            prev = None;
            continue;
        }
        let Some(c) = x.override_cmd_pct else {
            continue;
        };
        let faulty = !x.force_valid || x.flags.contains("link:");
        if faulty && prev.is_some_and(|p| c > p) {
            raised += 1;
        }
        prev = Some(c);
    }
    raised
}

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

/// `acc run` did not take the period's status read at face value: its row's `flags` carry
/// `link:` (the client rejected the frame), `implausible:<register>`,
/// `unconfirmed:<register>` (a change held a period for confirmation), `force_invalid`, or
/// `echo…` / `delay…` (the loop delay measured from the override's echo).
pub fn suspicious(flags: &str) -> bool {
    flags.split(';').any(|f| {
        f.starts_with("link:")
            || f.starts_with("implausible:")
            || f.starts_with("unconfirmed:")
            || f == "force_invalid"
            || f.starts_with("echo")
            || f.starts_with("delay")
    })
}

/// Whether an alteration of an FC04 reply changed something the controller acts on and
/// can tell from the frame alone, so that `acc run` must flag its period: every frame-level
/// kind (another slave, an exception, a wrong byte count, a truncated frame: the client must
/// reject them) and random contents; a flipped bit of a discrete or enumerated input
/// (`STATUS` bits 0…8, `OVERRIDE_APPLIED`, `OPERATOR_OVERRIDE`, `OVERRIDE_STEP`,
/// `PROTOCOL_VERSION`, `FALLBACK_OVERRIDE`) or one that takes the spindle power above
/// `max_power_w` (every `POWER_HI` bit). Not required: a flip of an analog value within its
/// range (the low power bits, `SPINDLE_RPM`, `SAMPLE_SEQ`, `PROGRAMMED_FEED`: nothing in
/// one frame tells it from a real change), of the NC context the loop only records
/// (registers 10…13), or of a reserved `STATUS` bit; and a delayed reply (well-formed and
/// consistent: only the measured loop delay can tell it).
pub fn must_be_flagged(e: &ProxyEvent, max_power_w: f64) -> bool {
    match e.kind.as_str() {
        "delay" => false,
        "flip" => match e.register {
            Some(0) => e.bit.is_some_and(|b| b <= 8),
            Some(1 | 2 | 3 | 4 | 9 | 14) => true,
            Some(5) => e.after.is_some_and(|a| a as f64 > max_power_w),
            _ => false,
        },
        _ => true,
    }
}

/// The proxy's FC04 reads matched to `acc run`'s rows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Alignment {
    /// Row index in the run log of each read index that has one.
    pub row_of_read: HashMap<u64, usize>,
    /// Rows with a logged power that were checked against the power the proxy handed over.
    pub checked: usize,
    /// Of which the power agreed.
    pub agreed: usize,
    /// Reads acc run made before its first logged period (the protocol probe).
    pub offset: u64,
}

impl Alignment {
    /// The match is trustworthy: at least 20 rows checked and 95 % of them agree.
    pub fn reliable(&self) -> bool {
        trustworthy(self.checked, self.agreed)
    }

    /// (checked, agreed) over the rows in `range` only: a long log may lose its match
    /// for a while (a row that logs a held power rather than the one read) and be matched
    /// well where it matters.
    pub fn agreement_in(
        &self,
        rows: &[RunRecord],
        reads: &[ProxyRead],
        range: std::ops::Range<usize>,
    ) -> (usize, usize) {
        let power: HashMap<u64, f64> = reads
            .iter()
            .filter_map(|r| Some((r.i?, r.power?)))
            .collect();
        let (mut checked, mut agreed) = (0, 0);
        for (read, &row) in &self.row_of_read {
            let Some(logged) = rows
                .get(row)
                .filter(|_| range.contains(&row))
                .and_then(|x| x.power_w)
            else {
                continue;
            };
            checked += 1;
            agreed += usize::from(power.get(read).is_some_and(|p| (p - logged).abs() < 0.5));
        }
        (checked, agreed)
    }
}

/// At least 20 rows checked and 95 % of them agree.
pub fn trustworthy(checked: usize, agreed: usize) -> bool {
    checked >= 20 && agreed * 100 >= checked * 95
}

/// Match the proxy's FC04 reads to `acc run`'s rows in order. Every row does one status
/// read, except the rows flagged `skipped` (no cycle ran); acc run reads before its first
/// period (one read on a v2 board, two on a v1 board that answers registers 9…14 with an
/// exception), and a client that falls back to the v1 register block re-reads within the
/// period. So row `j` (of those that read) is read `j + offset`, the offset starting at 0
/// … [`MAX_OFFSET`] and only growing, by one extra read at a time: the offsets are chosen
/// (dynamic programming) to make the fewest rows disagree with the power the proxy handed
/// over for their read, each change of offset costing as much as [`SHIFT_COST`]
/// disagreeing rows (a logged power repeats from period to period, so a single agreeing row
/// proves nothing). A row without a logged power (the read failed) agrees with any read.
pub fn align_reads(rows: &[RunRecord], reads: &[ProxyRead]) -> Alignment {
    let n = reads.iter().filter_map(|r| r.i).max().map_or(0, |m| m + 1) as usize;
    let mut power: Vec<Option<f64>> = vec![None; n];
    for r in reads {
        if let Some(i) = r.i {
            power[i as usize] = r.power;
        }
    }
    let with_read: Vec<usize> = (0..rows.len())
        .filter(|&j| !rows[j].flags.split(';').any(|f| f == "skipped"))
        .collect();
    let agrees = |row: usize, read: usize| -> Option<bool> {
        let logged = rows[row].power_w?;
        Some(matches!(power.get(read).copied().flatten(), Some(b) if (logged - b).abs() < 0.5))
    };
    // cost[k]: fewest disagreements (plus shift costs) up to this row with offset k now.
    const K: usize = MAX_OFFSET + 1;
    let mut cost = [0usize; K];
    let mut from: Vec<[usize; K]> = Vec::with_capacity(with_read.len());
    for (j, &row) in with_read.iter().enumerate() {
        let mut next = [usize::MAX; K];
        let mut back = [0usize; K];
        for k in 0..K {
            // Stay at k, or come from a smaller offset (extra reads in this period).
            let (best, prev) = (0..=k)
                .map(|p| {
                    let shift = if j > 0 && p < k {
                        SHIFT_COST * (k - p)
                    } else {
                        0
                    };
                    (cost[p].saturating_add(shift), p)
                })
                .min()
                .unwrap_or((usize::MAX, k));
            let miss = usize::from(agrees(row, j + k) == Some(false));
            next[k] = best.saturating_add(miss);
            back[k] = prev;
        }
        cost = next;
        from.push(back);
    }
    let mut a = Alignment::default();
    let Some(mut k) = (0..K).min_by_key(|&k| (cost[k], k)) else {
        return a;
    };
    for (j, &row) in with_read.iter().enumerate().rev() {
        let read = j + k;
        a.row_of_read.insert(read as u64, row);
        if let Some(agree) = agrees(row, read) {
            a.checked += 1;
            a.agreed += usize::from(agree);
        }
        if j == 0 {
            a.offset = k as u64;
        }
        k = from[j][k];
    }
    a
}

/// Largest offset between the proxy's read count and `acc run`'s rows [`align_reads`]
/// considers (start-up reads plus re-reads within a period).
pub const MAX_OFFSET: usize = 8;
/// Cost of one extra read in [`align_reads`], in disagreeing rows.
pub const SHIFT_COST: usize = 4;

/// Replace the text between `<!-- {name}:begin -->` and `<!-- {name}:end -->` in `doc`.
pub fn update_between(doc: &Path, name: &str, table: &str) -> anyhow::Result<()> {
    let begin = format!("<!-- {name}:begin -->");
    let end = format!("<!-- {name}:end -->");
    let text = std::fs::read_to_string(doc).with_context(|| format!("{}", doc.display()))?;
    let (Some(b), Some(e)) = (text.find(&begin), text.find(&end)) else {
        bail!(
            "{}: no `{begin}` … `{end}` markers to put the table between",
            doc.display()
        );
    };
    if e < b {
        bail!("{}: `{end}` comes before `{begin}`", doc.display());
    }
    let new = format!("{}{begin}\n{table}{}", &text[..b], &text[e..]);
    std::fs::write(doc, new).with_context(|| format!("{}", doc.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(power: Option<f64>, flags: &str) -> RunRecord {
        RunRecord {
            power_w: power,
            flags: flags.into(),
            ..RunRecord::default()
        }
    }

    fn read(i: u64, power: Option<f64>) -> ProxyRead {
        ProxyRead {
            i: Some(i),
            power,
            applied: None,
            altered: false,
        }
    }

    #[test]
    fn reads_align_with_the_start_up_read_a_failed_read_and_a_re_read() {
        // Powers repeat (1176 over and over) as in a steady cut.
        let p = [
            700.0, 1176.0, 1176.0, 1103.0, 1153.0, 1176.0, 1176.0, 1176.0, 1103.0, 1153.0, 1176.0,
            1176.0, 1103.0, 1081.0, 1154.0, 1176.0, 1176.0, 1103.0,
        ];
        // Read 0 is the start-up read; read 6 is garbage (the row logs the last good power);
        // read 10 got exception 02 and the client re-read at once (read 11).
        let mut reads: Vec<ProxyRead> = p
            .iter()
            .enumerate()
            .map(|(i, &w)| read(i as u64, Some(w)))
            .collect();
        reads[6].power = Some(2_647_218_006.0);
        reads[10].power = None;
        let mut rows = Vec::new();
        for (i, &w) in p.iter().enumerate().skip(1) {
            if i == 10 {
                continue; // the re-read's row is the next one
            }
            let logged = if i == 6 { Some(1176.0) } else { Some(w) };
            rows.push(row(logged, ""));
        }
        rows.insert(3, row(None, "skipped"));
        let a = align_reads(&rows, &reads);
        assert_eq!(a.offset, 1);
        assert_eq!(a.row_of_read[&1], 0);
        assert_eq!(a.row_of_read[&3], 2);
        assert_eq!(a.row_of_read[&4], 4, "the skipped row did not read");
        assert_eq!(a.row_of_read[&6], 6);
        assert_eq!(a.row_of_read[&11], 10, "the re-read within the period");
        assert_eq!(a.row_of_read[&17], rows.len() - 1);
        assert!(!a.row_of_read.contains_key(&10));
        assert_eq!((a.checked, a.agreed), (16, 15));
        assert!(!a.reliable(), "fewer than 20 rows checked");
    }

    #[test]
    fn suspicious_flags_and_the_alterations_that_must_be_flagged() {
        assert!(suspicious("link:timeout"));
        assert!(suspicious("seq_skip:2;implausible:power"));
        assert!(suspicious("unconfirmed:status;fault"));
        assert!(suspicious("force_invalid"));
        assert!(suspicious("delay:4/3"));
        assert!(!suspicious("seq_skip:2;late;write:timeout;fault"));
        assert!(!suspicious(""));
        let ev =
            |kind: &str, register: Option<u16>, bit: Option<u8>, after: Option<i64>| ProxyEvent {
                t: 0.0,
                read_index: Some(1),
                fc: 4,
                kind: kind.into(),
                register,
                bit,
                before: None,
                after,
            };
        for kind in ["slave", "exception", "bytecount", "truncate", "random"] {
            assert!(must_be_flagged(&ev(kind, None, None, None), 30_000.0));
        }
        assert!(!must_be_flagged(
            &ev("delay", Some(7), None, Some(3)),
            30_000.0
        ));
        assert!(must_be_flagged(
            &ev("flip", Some(0), Some(0), None),
            30_000.0
        ));
        assert!(!must_be_flagged(
            &ev("flip", Some(0), Some(12), None),
            30_000.0
        ));
        assert!(must_be_flagged(
            &ev("flip", Some(2), Some(0), None),
            30_000.0
        ));
        assert!(must_be_flagged(
            &ev("flip", Some(4), Some(0), None),
            30_000.0
        ));
        assert!(must_be_flagged(
            &ev("flip", Some(5), Some(15), Some(33_000)),
            30_000.0
        ));
        assert!(!must_be_flagged(
            &ev("flip", Some(5), Some(3), Some(1_184)),
            30_000.0
        ));
        assert!(!must_be_flagged(
            &ev("flip", Some(7), Some(3), None),
            30_000.0
        ));
        assert!(!must_be_flagged(
            &ev("flip", Some(12), Some(3), None),
            30_000.0
        ));
    }

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
