//! The summary of a program run, per block and per tool, from the run log's `block` and
//! `tool` columns (what the board reported): time in the block, peak and mean force against
//! Fr, the mean override. The 1-D scenarios' per-segment summary is [`crate::summary`].

use std::fmt;

use acc_runtime::record::RunRecord;

/// One block (or one stretch of it: a block the tool comes back to is a new row).
#[derive(Debug, Clone, PartialEq)]
pub struct BlockRow {
    /// Tool number the board reported.
    pub tool: u16,
    /// Block number the board reported (the N word, else the line number).
    pub block: u16,
    /// Time the block started and ended, s.
    pub enter_s: f64,
    /// See `enter_s`.
    pub leave_s: f64,
    /// Largest estimated force in the block, N.
    pub peak_force_n: f64,
    /// Largest true force in the block (simulator only), N.
    pub peak_true_n: Option<f64>,
    /// Mean estimated force over the rows with a force above 5 % of Fr, N (`None`: air).
    pub mean_force_n: Option<f64>,
    /// Mean applied override, %.
    pub mean_override_pct: f64,
}

/// Per tool: time, peak and mean override.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolRow {
    /// Tool number.
    pub tool: u16,
    /// Blocks (stretches) run with it.
    pub blocks: usize,
    /// Time with it, s.
    pub time_s: f64,
    /// Time cutting (force above 5 % of Fr), s.
    pub cutting_s: f64,
    /// Largest estimated force, N.
    pub peak_force_n: f64,
    /// Mean applied override while cutting, %.
    pub mean_override_pct: f64,
}

/// The summary of a program run.
#[derive(Debug, Clone, PartialEq)]
pub struct ProgramSummary {
    /// Force reference Fr, N.
    pub force_ref_n: f64,
    /// Per block, in order.
    pub blocks: Vec<BlockRow>,
    /// Per tool, in order of first use.
    pub tools: Vec<ToolRow>,
    /// Cycle time, s.
    pub cycle_s: f64,
    /// Force RMS error against Fr over the rows cutting, N.
    pub rms_error_n: f64,
}

/// A row counts as cutting when its force is above this share of Fr (a program's rows are
/// attributed to cuts by force: its path has no segments that say where the cuts are).
pub const CUTTING_SHARE_OF_FR: f64 = 0.05;

/// Whether `row` is cutting: its force above [`CUTTING_SHARE_OF_FR`] of `force_ref_n` (N).
pub fn is_cutting(row: &RunRecord, force_ref_n: f64) -> bool {
    row.force_n
        .is_some_and(|f| f > CUTTING_SHARE_OF_FR * force_ref_n)
}

/// Summarise `rows` with the force reference `force_ref_n` (N) and control period
/// `period_s` (s).
pub fn summarize_program(rows: &[RunRecord], force_ref_n: f64, period_s: f64) -> ProgramSummary {
    let cutting = |r: &RunRecord| is_cutting(r, force_ref_n);
    let mut blocks: Vec<BlockRow> = Vec::new();
    let mut sums: Vec<(f64, usize, f64, usize)> = Vec::new();
    for r in rows {
        let (tool, block) = (r.tool.unwrap_or(0), r.block.unwrap_or(0));
        let f = r.force_n.unwrap_or(0.0);
        let ov = f64::from(r.override_applied_pct.unwrap_or(0));
        let same = blocks
            .last()
            .is_some_and(|b| b.tool == tool && b.block == block);
        if !same {
            blocks.push(BlockRow {
                tool,
                block,
                enter_s: r.t_s - period_s,
                leave_s: r.t_s,
                peak_force_n: f,
                peak_true_n: r.force_true_n,
                mean_force_n: None,
                mean_override_pct: 0.0,
            });
            sums.push((0.0, 0, 0.0, 0));
        }
        let (Some(b), Some(s)) = (blocks.last_mut(), sums.last_mut()) else {
            continue;
        };
        b.leave_s = r.t_s;
        b.peak_force_n = b.peak_force_n.max(f);
        b.peak_true_n = match (b.peak_true_n, r.force_true_n) {
            (Some(a), Some(t)) => Some(a.max(t)),
            (a, t) => a.or(t),
        };
        s.2 += ov;
        s.3 += 1;
        if cutting(r) {
            s.0 += f;
            s.1 += 1;
        }
    }
    for (b, s) in blocks.iter_mut().zip(&sums) {
        b.mean_force_n = (s.1 > 0).then(|| s.0 / s.1 as f64);
        b.mean_override_pct = s.2 / s.3.max(1) as f64;
    }
    let mut tools: Vec<ToolRow> = Vec::new();
    for r in rows {
        let tool = r.tool.unwrap_or(0);
        let i = match tools.iter().position(|t| t.tool == tool) {
            Some(i) => i,
            None => {
                tools.push(ToolRow {
                    tool,
                    blocks: 0,
                    time_s: 0.0,
                    cutting_s: 0.0,
                    peak_force_n: 0.0,
                    mean_override_pct: 0.0,
                });
                tools.len() - 1
            }
        };
        let t = &mut tools[i];
        t.time_s += period_s;
        t.peak_force_n = t.peak_force_n.max(r.force_n.unwrap_or(0.0));
        if cutting(r) {
            t.cutting_s += period_s;
            t.mean_override_pct += f64::from(r.override_applied_pct.unwrap_or(0)) * period_s;
        }
    }
    for t in &mut tools {
        t.blocks = blocks.iter().filter(|b| b.tool == t.tool).count();
        t.mean_override_pct /= t.cutting_s.max(f64::EPSILON);
    }
    let errs: Vec<f64> = rows
        .iter()
        .filter(|r| cutting(r))
        .filter_map(|r| Some(r.force_n? - force_ref_n))
        .collect();
    let rms_error_n = if errs.is_empty() {
        0.0
    } else {
        (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt()
    };
    ProgramSummary {
        force_ref_n,
        blocks,
        tools,
        cycle_s: rows.last().map_or(0.0, |r| r.t_s),
        rms_error_n,
    }
}

impl ProgramSummary {
    /// The blocks as CSV (`tool,block,enter_s,leave_s,peak_force_n,peak_over_fr,...`).
    pub fn blocks_csv(&self) -> String {
        let mut s = String::from(
            "tool,block,enter_s,leave_s,peak_force_n,peak_over_fr,peak_true_n,mean_force_n,mean_override_pct\n",
        );
        let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.1}"));
        for b in &self.blocks {
            s.push_str(&format!(
                "{},{},{:.1},{:.1},{:.1},{:.3},{},{},{:.1}\n",
                b.tool,
                b.block,
                b.enter_s,
                b.leave_s,
                b.peak_force_n,
                b.peak_force_n / self.force_ref_n,
                opt(b.peak_true_n),
                opt(b.mean_force_n),
                b.mean_override_pct
            ));
        }
        s
    }
}

impl fmt::Display for ProgramSummary {
    /// The per-tool table and the ten blocks with the highest peak.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{:>5} {:>7} {:>9} {:>9} {:>9} {:>9} {:>7}",
            "tool", "blocks", "time_s", "cut_s", "peak_N", "peak/Fr", "ovr_%"
        )?;
        for t in &self.tools {
            writeln!(
                f,
                "{:>5} {:>7} {:>9.1} {:>9.1} {:>9.1} {:>9.3} {:>7.1}",
                t.tool,
                t.blocks,
                t.time_s,
                t.cutting_s,
                t.peak_force_n,
                t.peak_force_n / self.force_ref_n,
                t.mean_override_pct
            )?;
        }
        let mut top: Vec<&BlockRow> = self.blocks.iter().collect();
        top.sort_by(|a, b| b.peak_force_n.total_cmp(&a.peak_force_n));
        writeln!(f, "highest peaks ({} blocks in all):", self.blocks.len())?;
        writeln!(
            f,
            "{:>5} {:>7} {:>9} {:>9} {:>9} {:>9} {:>7}",
            "tool", "block", "enter_s", "leave_s", "peak_N", "peak/Fr", "ovr_%"
        )?;
        for b in top.iter().take(10) {
            writeln!(
                f,
                "{:>5} {:>7} {:>9.1} {:>9.1} {:>9.1} {:>9.3} {:>7.1}",
                b.tool,
                b.block,
                b.enter_s,
                b.leave_s,
                b.peak_force_n,
                b.peak_force_n / self.force_ref_n,
                b.mean_override_pct
            )?;
        }
        writeln!(
            f,
            "cycle time {:.1} s; force RMS error while cutting {:.1} N (Fr {:.0} N)",
            self.cycle_s, self.rms_error_n, self.force_ref_n
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t: f64, tool: u16, block: u16, f: f64, ov: u16) -> RunRecord {
        RunRecord {
            t_s: t,
            tool: Some(tool),
            block: Some(block),
            force_n: Some(f),
            override_applied_pct: Some(ov),
            ..RunRecord::default()
        }
    }

    #[test]
    fn blocks_and_tools_are_grouped_in_order() {
        let rows = vec![
            row(0.1, 1, 10, 0.0, 100),
            row(0.2, 1, 20, 900.0, 100),
            row(0.3, 1, 20, 800.0, 90),
            row(0.4, 2, 30, 700.0, 80),
            row(0.5, 1, 20, 100.0, 100),
        ];
        let s = summarize_program(&rows, 800.0, 0.1);
        let b: Vec<(u16, u16)> = s.blocks.iter().map(|b| (b.tool, b.block)).collect();
        assert_eq!(b, vec![(1, 10), (1, 20), (2, 30), (1, 20)]);
        assert_eq!(s.blocks[1].peak_force_n, 900.0);
        assert_eq!(s.blocks[1].mean_force_n, Some(850.0));
        assert_eq!(s.blocks[0].mean_force_n, None);
        assert!((s.blocks[1].mean_override_pct - 95.0).abs() < 1e-9);
        assert_eq!(s.tools.len(), 2);
        assert_eq!(s.tools[0].blocks, 3);
        assert!((s.tools[0].time_s - 0.4).abs() < 1e-9);
        assert!((s.tools[0].cutting_s - 0.3).abs() < 1e-9);
        // Cutting rows: 900, 800, 700, 100 against 800.
        let want = ((100.0f64.powi(2) + 0.0 + 100.0f64.powi(2) + 700.0f64.powi(2)) / 4.0).sqrt();
        assert!((s.rms_error_n - want).abs() < 1e-9);
        assert!(s.blocks_csv().lines().count() == 5);
        assert!(s.to_string().contains("highest peaks (4 blocks in all)"));
    }
}
