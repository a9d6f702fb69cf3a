//! The `acc` child processes of the harness: this same `acc` binary started as `acc
//! board-sim` / `acc run` (or another program, the proxy), their stderr collected line by
//! line (and copied to a file), signals sent with kill(1), their exit statuses as the tables
//! show them, their memory and threads from `/proc`, and their run logs read back.

use std::ffi::OsStr;
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
    /// Start `acc <args>` (the running executable: the harness runs inside the `acc`
    /// binary) with stdout/stderr copied into `dir/<name>.stdout|.stderr`; for
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
