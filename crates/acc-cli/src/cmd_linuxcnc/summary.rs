//! What one `acc linuxcnc` run did, from its files: the machine log of `acc-process`
//! (`machine.csv`), acc's run log (`run.csv`) and the UI script's `ui.log`.

use std::path::Path;

use anyhow::Context as _;

/// The machine log: one reader for the summary and the fault matrix
/// ([`acc_linuxcnc::machine_log`]; its errors name the file and the line).
pub use acc_linuxcnc::machine_log::{read as read_machine_log, MachineRow};

/// acc's run log at `path` with the machine log's truth: each period's `force_true_n` is
/// the mean true force of the machine-log rows in it, as the simulator logs it ("true mean
/// cutting force over what the sensor looked at"; the machine log's own rows, every 2 ms,
/// peak higher within a period) (`x_true_mm`, `radial_depth_mm`,
/// `axial_depth_mm`, `feed_true_mm_min` from its last row). The run log goes onto the
/// machine log's clock by acc's first heartbeat toggle (its first status read, to within a
/// period); a period the machine log does not cover (the process died) keeps no truth.
pub fn run_log_with_truth(
    path: &Path,
    machine: &[MachineRow],
    period_s: f64,
) -> anyhow::Result<Vec<acc_runtime::record::RunRecord>> {
    let file = std::fs::File::open(path)
        .with_context(|| format!("{}: cannot read the run log", path.display()))?;
    let mut rows = acc_runtime::record::read_run_log(file)
        .with_context(|| format!("{}: the run log", path.display()))?;
    let first_beat = machine
        .windows(2)
        .position(|w| w[0].heartbeat != w[1].heartbeat)
        .map(|k| machine[k + 1].t_s);
    let offset = match (first_beat, rows.first()) {
        (Some(t), Some(r0)) => t - r0.t_s,
        _ => return Ok(rows),
    };
    let end = machine.last().map_or(0.0, |r| r.t_s);
    for r in &mut rows {
        let t1 = r.t_s + offset;
        let (t0, t1) = (t1 - period_s, t1);
        if t1 > end {
            continue;
        }
        let a = machine.partition_point(|m| m.t_s < t0);
        let b = machine.partition_point(|m| m.t_s < t1);
        let Some(last) = machine[a..b].last() else {
            continue;
        };
        let rows_in = &machine[a..b];
        r.force_true_n =
            Some(rows_in.iter().map(|m| m.force_n).sum::<f64>() / rows_in.len() as f64);
        r.x_true_mm = Some(last.x_mm);
        r.radial_depth_mm = Some(last.radial_mm);
        r.axial_depth_mm = Some(last.axial_mm);
        r.feed_true_mm_min = Some(last.feed_mm_min);
    }
    Ok(rows)
}

/// `blocks.csv` in `dir` (as `acc sim --program` writes it: per NC block, from the run log's
/// `block` = `motion.program-line`, peak and mean force, the true peak from the machine
/// log, the mean override, the time in the block) and the summary it came from.
pub fn write_blocks(
    dir: &Path,
    machine: &[MachineRow],
    force_ref_n: f64,
    period_s: f64,
) -> anyhow::Result<acc_sim::program_summary::ProgramSummary> {
    let rows = run_log_with_truth(&dir.join("run.csv"), machine, period_s)?;
    let s = acc_sim::program_summary::summarize_program(&rows, force_ref_n, period_s);
    let csv = dir.join("blocks.csv");
    std::fs::write(&csv, s.blocks_csv())
        .with_context(|| format!("{}: cannot write", csv.display()))?;
    Ok(s)
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

/// The process's path against the `halsampler` capture at `capture`
/// ([`acc_linuxcnc::halsampler::compare`]), printed; an error if the capture is missing or
/// unreadable.
pub fn print_path_match(capture: &Path, machine: &[MachineRow]) -> anyhow::Result<()> {
    let c = acc_linuxcnc::halsampler::read(capture)?;
    let m = acc_linuxcnc::halsampler::compare(machine, &c);
    println!(
        "path: {} machine-log rows against LinuxCNC's joint positions ({}, {} servo periods, {} overruns; {} rows outside it), the joints {} servo periods behind the axis command: at most {:.4} mm apart, {:.4} mm while cutting (the joints move up to {:.4} mm in a servo period)",
        m.rows,
        capture.display(),
        c.samples.len(),
        c.overruns,
        m.rows_outside,
        m.lag_periods,
        m.max_mm,
        m.max_cutting_mm,
        m.max_step_mm
    );
    Ok(())
}

/// The errors LinuxCNC reported during the run (`ui.py` logs its error channel's errors as
/// `<t> error <text>`), in order; empty without `ui.log`.
pub fn errors(ui_log: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(ui_log).unwrap_or_default();
    text.lines()
        .filter_map(|l| Some(l.split_once(" error ")?.1.trim().to_string()))
        .collect()
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
            adaptive_feed: 1.0,
            heartbeat: beat,
            ..MachineRow::default()
        }
    }

    #[test]
    fn the_run_log_gets_the_machine_logs_truth_on_its_clock() {
        // Machine log every 10 ms from 0 to 1 s; acc's first read toggles the heartbeat
        // at 0.3 s; the force ramps with time (N = 1000 × t).
        let machine: Vec<MachineRow> = (0..=100)
            .map(|k| {
                let t = 0.01 * f64::from(k);
                MachineRow {
                    t_s: t,
                    force_n: 1000.0 * t,
                    heartbeat: t >= 0.3 && ((t * 10.0 + 1e-9) as u64) % 2 == 1,
                    ..MachineRow::default()
                }
            })
            .collect();
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("run.csv");
        let mut w =
            acc_runtime::record::RunLogWriter::new(std::fs::File::create(&path).expect("f"))
                .expect("writer");
        for k in 0..12u32 {
            let rec = acc_runtime::record::RunRecord {
                t_s: 0.1 * f64::from(k),
                period: u64::from(k),
                ..Default::default()
            };
            w.write(&rec).expect("row");
        }
        drop(w);
        let rows = run_log_with_truth(&path, &machine, 0.1).expect("read");
        // Period 0 is the first read (0.3 s on the machine clock): the mean of the rows of
        // 0.2 ..< 0.3 s.
        let p0 = rows[0].force_true_n.expect("truth");
        assert!((p0 - 245.0).abs() < 1e-6, "{p0}");
        let p2 = rows[2].force_true_n.expect("truth");
        assert!((p2 - 445.0).abs() < 1e-6, "{p2}");
        // Beyond the machine log's end: no truth.
        assert_eq!(rows[11].force_true_n, None);
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
