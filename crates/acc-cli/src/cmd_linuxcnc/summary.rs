//! What one `acc linuxcnc` run did, from its files: the machine log of `acc-process`
//! (`machine.csv`), acc's run log (`run.csv`) and the UI script's `ui.log`.

use std::path::Path;

use anyhow::Context as _;

/// One machine-log row, the columns the summary reads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MachineRow {
    /// Time since the process started, s.
    pub t_s: f64,
    /// Path speed, mm/min.
    pub feed_mm_min: f64,
    /// True force, N.
    pub force_n: f64,
    /// The adaptive feed acc wrote, 0 ..= 1.
    pub adaptive_feed: f64,
    /// acc's heartbeat bit.
    pub heartbeat: bool,
}

/// The machine log at `path`.
pub fn read_machine_log(path: &Path) -> anyhow::Result<Vec<MachineRow>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read the machine log", path.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or_else(|| anyhow::anyhow!("{}: no column `{name}`", path.display()))
    };
    let (t, feed, force, adaptive, beat) = (
        col("t_s")?,
        col("feed_mm_min")?,
        col("force_n")?,
        col("adaptive_feed")?,
        col("heartbeat")?,
    );
    let mut rows = Vec::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let num = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok());
        // A last line cut short by a killed process is skipped.
        if let (Some(t_s), Some(feed_mm_min), Some(force_n), Some(adaptive_feed), Some(b)) =
            (num(t), num(feed), num(force), num(adaptive), num(beat))
        {
            rows.push(MachineRow {
                t_s,
                feed_mm_min,
                force_n,
                adaptive_feed,
                heartbeat: b != 0.0,
            });
        }
    }
    Ok(rows)
}

/// The run log's periods (column `period`) at `path`.
pub fn run_log_periods(path: &Path) -> anyhow::Result<Vec<u64>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read the run log", path.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let i = header
        .iter()
        .position(|h| *h == "period")
        .ok_or_else(|| anyhow::anyhow!("{}: no column `period`", path.display()))?;
    Ok(lines
        .filter_map(|l| l.split(',').nth(i).and_then(|v| v.parse().ok()))
        .collect())
}

/// `cycle_s` of `ui.log` (program start to idle), if the program ran to its end.
pub fn cycle_s(ui_log: &Path) -> Option<f64> {
    let text = std::fs::read_to_string(ui_log).ok()?;
    text.lines().find_map(|l| {
        l.split_once(" cycle_s ")
            .and_then(|(_, v)| v.trim().parse().ok())
    })
}

/// How long the motion took to stop after acc's heartbeat stopped: from the last change of
/// the heartbeat bit (acc's last period; the kill came within one period after it) to the
/// first row with the feed at 0 after it, s. `None` if the heartbeat never stopped while
/// the machine moved (no kill) or the motion never stopped.
pub fn stop_after_heartbeat_s(rows: &[MachineRow]) -> Option<f64> {
    let last_change = rows
        .windows(2)
        .rposition(|w| w[0].heartbeat != w[1].heartbeat)?
        + 1;
    let t0 = rows[last_change].t_s;
    // Moving when the heartbeat stopped (else it stopped out of a cut, e.g. at the end).
    if rows[last_change].feed_mm_min <= 0.0 {
        return None;
    }
    // The heartbeat must have stayed silent for longer than its period: a kill.
    if rows.last()?.t_s - t0 < 0.5 {
        return None;
    }
    rows[last_change..]
        .iter()
        .find(|r| r.feed_mm_min <= 0.0)
        .map(|r| r.t_s - t0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t_s: f64, feed: f64, beat: bool) -> MachineRow {
        MachineRow {
            t_s,
            feed_mm_min: feed,
            force_n: 0.0,
            adaptive_feed: 1.0,
            heartbeat: beat,
        }
    }

    #[test]
    fn the_stop_is_timed_from_the_last_heartbeat_to_zero_feed() {
        let mut rows: Vec<MachineRow> = (0..50)
            .map(|k| row(0.01 * f64::from(k), 300.0, (k / 10) % 2 == 1))
            .collect();
        // The heartbeat's last change at 0.4 s, the feed at 0 from 0.72 s, logged to 2 s.
        for k in 50..200 {
            let t = 0.01 * f64::from(k);
            rows.push(row(t, if t >= 0.72 { 0.0 } else { 300.0 }, false));
        }
        let s = stop_after_heartbeat_s(&rows).expect("a stop");
        assert!((s - 0.32).abs() < 1e-9, "{s}");
        // A heartbeat that runs to the end: no kill.
        let live: Vec<MachineRow> = (0..100)
            .map(|k| row(0.01 * f64::from(k), 300.0, (k / 10) % 2 == 1))
            .collect();
        assert_eq!(stop_after_heartbeat_s(&live), None);
    }
}
