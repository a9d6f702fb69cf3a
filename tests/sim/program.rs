//! NC programs on the simulated machine (`acc sim --program`): the production loop on a
//! plant whose engagement comes from a Z-map stock cut along the interpreted path. The
//! board reports the program's blocks and tools, rapids are not overridden, the loop
//! regulates the cut, and bad programs are refused before anything runs.

use std::path::PathBuf;

use crate::e2e_support::{acc_output as acc, pocket_program, read_log, root};
use acc_sim::engagement::{EngagementSource, ToolGeometry};
use acc_sim::program::{ProgramPath, ProgramSpec, StockSource};
use acc_sim::{LawKind, Scenario};

fn scenario() -> Scenario {
    Scenario::load(root().join("configs/scenarios/paper_case3.toml")).expect("scenario")
}

const POCKET_BOX: &str = "-20,-20,-10,60,50,0";

#[test]
fn the_loop_runs_a_pocket_program_and_the_board_reports_its_blocks() {
    let base = scenario();
    let path = pocket_program(&base, POCKET_BOX);
    let sc = path.scenario_for(&base);
    let mut law = sc.build_law(LawKind::Ours).expect("law");
    let run = crate::e2e_support::run_program(&sc, &path, law.as_mut(), None);
    assert!(run.finished, "the program ran to its end");
    // The blocks the board reported are the program's, in program order.
    let program_blocks: Vec<u16> = path
        .segments()
        .iter()
        .map(|s| s.block.unwrap_or(s.line) as u16)
        .collect();
    let mut logged: Vec<u16> = run.rows.iter().filter_map(|r| r.block).collect();
    logged.dedup();
    let mut k = 0;
    for b in &logged {
        while k < program_blocks.len() && program_blocks[k] != *b {
            k += 1;
        }
        assert!(k < program_blocks.len(), "block {b} out of program order");
    }
    assert!(logged.len() >= 20, "{logged:?}");
    assert!(run.rows.iter().all(|r| r.tool == Some(1)));
    // A rapid runs at the rapid rate whatever the override: the fastest true feed of the
    // run is close to 10 000 mm/min, far above 150 % of any F word (900 mm/min).
    let fastest = run
        .rows
        .iter()
        .filter_map(|r| r.feed_true_mm_min)
        .fold(0.0, f64::max);
    assert!(fastest > 5000.0, "fastest feed {fastest:.0} mm/min");
    // The loop regulates the steady cut: after the entries, the median force of the
    // cutting rows is within 10 % of Fr.
    let fr = sc.controller.force_ref_n;
    let mut cut: Vec<f64> = run
        .rows
        .iter()
        .filter_map(|r| r.force_true_n.filter(|f| *f > 0.3 * fr))
        .collect();
    cut.sort_by(f64::total_cmp);
    let median = cut[cut.len() / 2];
    assert!(
        (median - fr).abs() < 0.1 * fr,
        "median cutting force {median:.0} N"
    );
    // The engagement the plant read is the stock's: the metal removed matches the sweep's
    // but for the two plunges (Z−2 and Z−4 with the Ø16 mm tool: 2 × π·8²·2 mm = 804 mm³),
    // which the stock removes and the plant's side-milling force law does not see.
    let plunges = 2.0 * std::f64::consts::PI * 8.0 * 8.0 * 2.0;
    assert!(
        (run.volume_mm3 + plunges - path.removed_mm3()).abs() < 0.01 * path.removed_mm3(),
        "plant {:.0} mm³, stock {:.0} mm³",
        run.volume_mm3,
        path.removed_mm3()
    );
}

#[test]
fn a_program_answers_feed_block_and_tool_along_its_path() {
    let sc = scenario();
    let path = pocket_program(&sc, POCKET_BOX);
    let len = path.path_length_mm().expect("length");
    assert!(len > 700.0, "{len}");
    // The first piece is the rapid to the start: the rapid rate, not overridden.
    let first = path.path_at(0.1).expect("point");
    assert!(first.rapid && first.feed_mm_min == sc.machine.feed_drive.rapid_mm_min);
    // The first slotting move (G1 X35 F600) engages the full cutter width.
    let seg = path
        .segments()
        .iter()
        .position(|s| !s.rapid && s.feed_mm_min == 600.0)
        .expect("slot");
    let start: f64 = path.segments()[..seg].iter().map(|s| s.length_mm()).sum();
    // Entries: the slotting entry of each of the two levels (and the finishing passes'
    // re-entries); corners: the zig-zag turns and the finishing rectangle's, in order.
    let ev = path.events();
    use acc_sim::program::EventKind;
    let entries: Vec<_> = ev.iter().filter(|e| e.kind == EventKind::Entry).collect();
    let corners = ev.iter().filter(|e| e.kind == EventKind::Corner).count();
    assert!(entries.len() >= 2 && corners >= 8, "{ev:?}");
    assert!(
        (entries[0].at_mm - start).abs() < 1.0,
        "{:?} vs {start}",
        entries[0]
    );
    assert!(ev.windows(2).all(|w| w[0].at_mm <= w[1].at_mm));
    let mut p = path.clone();
    let e = p.engagement_at(&ToolGeometry::of(&sc.tool), start + 10.0);
    assert!(
        (e.radial_mm - sc.tool.diameter_mm).abs() < 0.5 && (e.axial_mm - 2.0).abs() < 0.3,
        "{e:?}"
    );
}

#[test]
fn a_program_that_leaves_the_machines_travel_is_refused_with_its_line() {
    let dir = tempfile::tempdir().expect("dir");
    let far = dir.path().join("far.ngc");
    std::fs::write(
        &far,
        "G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z-1 F100\nG1 X300 F500\nM30\n",
    )
    .expect("write");
    let sc = scenario();
    let spec = ProgramSpec {
        program: far,
        stock: StockSource::Box("0,0,-5,20,20,0".parse().expect("box"), 0.25),
        tools: None,
    };
    let travel = acc_sim::config::Travel {
        x_mm: [-250.0, 250.0],
        y_mm: [-200.0, 200.0],
        z_mm: [-300.0, 150.0],
    };
    let build =
        |t| ProgramPath::build_within(&spec, &ToolGeometry::of(&sc.tool), 600.0, 10_000.0, t);
    let err = build(Some(&travel)).expect_err("refused").to_string();
    assert!(
        err.contains("far.ngc:4") && err.contains("X 300") && err.contains("travel"),
        "{err}"
    );
    assert!(build(None).is_ok(), "without [travel] nothing is checked");
    // The machine file's [travel] is validated like every key.
    let text =
        std::fs::read_to_string(root().join("configs/machines/paper_vmc.toml")).expect("machine");
    let bad =
        format!("{text}\n[travel]\nx_mm = [10.0, -10.0]\ny_mm = [0.0, 1.0]\nz_mm = [0.0, 1.0]\n");
    let p = dir.path().join("m.toml");
    std::fs::write(&p, bad).expect("write");
    let e = acc_sim::config::MachineSpec::load(&p)
        .expect_err("refused")
        .to_string();
    assert!(e.contains("travel.x_mm") && e.contains("m.toml"), "{e}");
}

#[test]
fn acc_sim_program_writes_the_log_the_blocks_and_the_stock_picture() {
    let dir = tempfile::tempdir().expect("dir");
    let out = dir.path().to_string_lossy().into_owned();
    let (ok, stdout, stderr) = acc(&[
        "sim",
        "paper_case3",
        "--program",
        "tests/nc/contour_inside_corners.ngc",
        "--stock-box",
        "-10,-10,-10,70,65,0",
        "--out",
        &out,
    ]);
    assert!(ok, "{stdout}\n{stderr}");
    assert!(stdout.contains("highest peaks"), "{stdout}");
    let rows = read_log(&dir.path().join("run.csv"));
    assert!(rows.len() > 100);
    let blocks = std::fs::read_to_string(dir.path().join("blocks.csv")).expect("blocks.csv");
    assert!(blocks.starts_with("tool,block,"), "{blocks}");
    assert!(blocks.lines().count() > 5);
    for f in ["stock.svg", "stock.png", "run.png"] {
        let p: PathBuf = dir.path().join(f);
        assert!(
            std::fs::metadata(&p)
                .map(|m| m.len() > 1000)
                .unwrap_or(false),
            "{f}"
        );
    }
}

#[test]
fn bad_programs_and_stocks_are_refused_before_anything_runs() {
    let dir = tempfile::tempdir().expect("dir");
    let bad = dir.path().join("bad.ngc");
    std::fs::write(&bad, "G21 G90\nG1 X10 F100\nG93\nM30\n").expect("write");
    let out = dir.path().join("run");
    let out_s = out.to_string_lossy().into_owned();
    let bad_s = bad.to_string_lossy().into_owned();
    let (ok, _, err) = acc(&[
        "sim",
        "paper_case3",
        "--program",
        &bad_s,
        "--stock-box",
        "0,0,-5,20,20,0",
        "--out",
        &out_s,
    ]);
    assert!(!ok);
    assert!(err.contains("bad.ngc:3:1") && err.contains("G93"), "{err}");
    assert!(!out.join("run.csv").exists(), "nothing ran");
    // A tool the table does not list.
    let tbl = dir.path().join("tools.tbl");
    std::fs::write(&tbl, "T2 P2 Z0 D8 ;other\n").expect("write");
    let tbl_s = tbl.to_string_lossy().into_owned();
    let (ok, _, err) = acc(&[
        "sim",
        "paper_case3",
        "--program",
        "tests/nc/pocket_rect.ngc",
        "--tools",
        &tbl_s,
        "--stock-box",
        "0,0,-5,20,20,0",
        "--out",
        &out_s,
    ]);
    assert!(!ok);
    assert!(
        err.contains("pocket_rect.ngc") && err.contains("T1"),
        "{err}"
    );
    // No stock; a malformed box.
    let (ok, _, err) = acc(&[
        "sim",
        "paper_case3",
        "--program",
        "tests/nc/pocket_rect.ngc",
        "--out",
        &out_s,
    ]);
    assert!(!ok && err.contains("--stock"), "{err}");
    let (ok, _, err) = acc(&[
        "sim",
        "paper_case3",
        "--program",
        "tests/nc/pocket_rect.ngc",
        "--stock-box",
        "0,0,5",
        "--out",
        &out_s,
    ]);
    assert!(!ok && err.contains("--stock-box"), "{err}");
    // A program beside the stock cuts air: a warning, and the run goes on.
    let (ok, _, err) = acc(&[
        "sim",
        "paper_case3",
        "--program",
        "tests/nc/pocket_rect.ngc",
        "--stock-box",
        "200,200,-5,220,220,0",
        "--no-plot",
        "--out",
        &out_s,
    ]);
    assert!(ok, "{err}");
    assert!(err.contains("cuts air"), "{err}");
}
