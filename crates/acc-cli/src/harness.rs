//! Process harness shared by `acc fault-matrix` and `acc soak`: this same `acc` binary started
//! as `acc board-sim` / `acc run` children, their stderr collected line by line (and copied
//! to a file), signals sent with kill(1), run logs read back.

use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use acc_runtime::record::{read_run_log, RunRecord};
use anyhow::Context;

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
        let stdout_file = std::fs::File::create(dir.join(format!("{name}.stdout")))?;
        let mut cmd = Command::new(exe);
        cmd.args(args).stderr(Stdio::piped());
        let first_line = name == "board-sim";
        if first_line {
            cmd.stdout(Stdio::piped());
        } else {
            cmd.stdout(stdout_file);
        }
        let mut child = cmd
            .spawn()
            .with_context(|| format!("starting acc {name}"))?;
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
