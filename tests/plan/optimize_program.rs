//! Needs LinuxCNC's stand-alone interpreter `rs274` (Debian `linuxcnc-uspace`, `.ci/deps`)
//! for the path test and `../shared/data/nc/` for the third-party programs: without them
//! that part prints `SKIP: …` and passes, unless `CI` is set, then it fails.
//!
//! `acc optimize` (`acc_sim::optimize`): on our programs and the third-party ones,
//! - the optimized program has the same path as the original in `rs274`: the sequence of
//!   canonical calls without SET_FEED_RATE, with consecutive collinear STRAIGHT_FEEDs and
//!   consecutive ARC_FEEDs about the same centre in the same direction merged (on both
//!   sides), is the same call for call — end points, arc centres, N numbers and every other
//!   call — to rs274's 4 decimals;
//! - the plan of the optimized program predicts at most Fr at 100 % (the stock's 0.25 mm
//!   cells and the re-chorded arcs of the split blocks allow 3 %) where the original
//!   predicted more, and most of its air runs at the tool's air feed;
//! - a bad setting is refused naming the option and its range.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::e2e_support::{acc_output, root};
use acc_sim::optimize::{optimize, OptimizeParams, Optimized};
use acc_sim::plan::PlanParams;
use acc_sim::program::ProgramPath;
use acc_sim::Scenario;

/// The programs, their stock boxes (as `tests/nc/table.sh`) and the stock's cell, mm (the
/// large third-party stocks in 1 mm cells: the path test does not depend on the cell, and a
/// debug build sweeps 0.25 mm cells of them for minutes); `nc3:` is `../shared/data/nc/`.
const PROGRAMS: &[(&str, &str, f64)] = &[
    ("tests/nc/pocket_rect.ngc", "-20,-20,-10,60,50,0", 0.25),
    (
        "tests/nc/contour_inside_corners.ngc",
        "-10,-10,-10,70,65,0",
        0.25,
    ),
    ("tests/nc/stepped_face.ngc", "-10,-5,-10,70,45,0", 0.25),
    (
        "nc3:linuxcnc_hk_ba20_testmill.ngc",
        "-150,-20,-20,80,220,0",
        1.0,
    ),
    ("nc3:linuxcnc_arcspiral.ngc", "-60,-60,-10,60,60,0", 1.0),
    ("nc3:linuxcnc_3D_Chips.ngc", "-50,-50,-50,50,50,0", 1.0),
    // Cutter radius compensation: its blocks keep their F words' places, never split.
    ("tests/nc/comp_pocket.ngc", "-30,-25,-10,140,60,0", 0.5),
    (
        "nc3:linuxcnc_inside_corners.ngc",
        "-10,-10,-10,110,110,0",
        1.0,
    ),
];

fn skip_or_fail(reason: &str) {
    if std::env::var_os("CI").is_some() {
        panic!("CI is set and {reason}");
    }
    println!("SKIP: {reason}");
}

fn file_of(prog: &str) -> PathBuf {
    match prog.strip_prefix("nc3:") {
        Some(name) => root().join("../shared/data/nc").join(name),
        None => root().join(prog),
    }
}

fn scenario() -> Scenario {
    Scenario::load(root().join("configs/scenarios/paper_case3.toml")).expect("scenario")
}

fn build(sc: &Scenario, program: &Path, (stock_box, cell): (&str, f64)) -> ProgramPath {
    crate::e2e_support::program_path(sc, program, stock_box, cell)
}

const AIR_FEED: f64 = acc_config::DEFAULT_AIR_FEED_MM_MIN;

/// The program optimized, written to `dir`: (optimized file, result).
fn optimized(sc: &Scenario, file: &Path, path: &ProgramPath, dir: &Path) -> (PathBuf, Optimized) {
    let text = std::fs::read_to_string(file).expect("program");
    let params = OptimizeParams {
        plan: PlanParams::of(sc),
        min_segment_mm: 1.0,
        max_feed_mm_min: sc.machine.feed_drive.rapid_mm_min,
    };
    let name = file.display().to_string();
    let opt = optimize(&name, &text, path, &params, &|_| AIR_FEED).expect("optimize");
    let stem = file.file_stem().expect("stem").to_string_lossy();
    let out = dir.join(format!("{stem}.opt.ngc"));
    std::fs::write(&out, &opt.text).expect("write");
    (out, opt)
}

/// The programs present (the third-party ones skipped with a reason when absent).
fn present() -> Vec<(PathBuf, (&'static str, f64))> {
    let mut v = Vec::new();
    for (prog, stock, cell) in PROGRAMS {
        let f = file_of(prog);
        if f.is_file() {
            v.push((f, (*stock, *cell)));
        } else {
            skip_or_fail(&format!("{} is absent", f.display()));
        }
    }
    v
}

/// One canonical call as rs274 prints it: its name, N number and numbers (or its text).
#[derive(Debug, Clone, PartialEq)]
struct Call {
    name: String,
    block: String,
    args: Vec<f64>,
    text: String,
}

fn parse(out: &str) -> Vec<Call> {
    let mut calls = Vec::new();
    for line in out.lines() {
        let mut it = line.split_whitespace();
        let (Some(_seq), Some(block)) = (it.next(), it.next()) else {
            continue;
        };
        let rest: String = it.collect::<Vec<_>>().join(" ");
        let Some(open) = rest.find('(') else { continue };
        let name = rest[..open].trim().to_string();
        if name == "SET_FEED_RATE" {
            continue;
        }
        let args = rest[open + 1..rest.rfind(')').unwrap_or(rest.len())]
            .split([',', ' '])
            .filter_map(|s| s.trim().parse().ok())
            .collect();
        calls.push(Call {
            name,
            block: block.to_string(),
            args,
            text: rest,
        });
    }
    calls
}

/// Consecutive collinear STRAIGHT_FEEDs and consecutive ARC_FEEDs about the same centre in
/// the same direction, merged (the first's N number kept). Before the first motion the
/// start is unknown: rs274 starts at 0, 0, 0.
fn merged(calls: Vec<Call>) -> Vec<Call> {
    let mut out: Vec<Call> = Vec::with_capacity(calls.len());
    let mut pos = [0.0; 3];
    // Start of the last kept motion (for the collinearity test).
    let mut start = [0.0; 3];
    for c in calls {
        let end = match c.name.as_str() {
            "STRAIGHT_TRAVERSE" | "STRAIGHT_FEED" => Some([c.args[0], c.args[1], c.args[2]]),
            "ARC_FEED" => Some([c.args[0], c.args[1], c.args[5]]),
            _ => None,
        };
        let joined = match (out.last_mut(), end) {
            (Some(last), Some(e)) if last.name == c.name && c.name == "STRAIGHT_FEED" => {
                let d1 = [0, 1, 2].map(|k| pos[k] - start[k]);
                let d2 = [0, 1, 2].map(|k| e[k] - pos[k]);
                let n = |d: [f64; 3]| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let cross = [
                    d1[1] * d2[2] - d1[2] * d2[1],
                    d1[2] * d2[0] - d1[0] * d2[2],
                    d1[0] * d2[1] - d1[1] * d2[0],
                ];
                let dot: f64 = (0..3).map(|k| d1[k] * d2[k]).sum();
                // The joint off the line from the start to the new end by less than
                // rs274's rounding, same direction.
                let chord = [0, 1, 2].map(|k| d1[k] + d2[k]);
                let same = dot > 0.0 && n(cross) / n(chord).max(1e-9) < 2e-4;
                if same {
                    last.args = c.args.clone();
                }
                same
            }
            (Some(last), Some(_)) if last.name == c.name && c.name == "ARC_FEED" => {
                let same = (last.args[2] - c.args[2]).abs() < 2e-4
                    && (last.args[3] - c.args[3]).abs() < 2e-4
                    && last.args[4].signum() == c.args[4].signum();
                if same {
                    let turns = last.args[4];
                    last.args = c.args.clone();
                    last.args[4] = turns.signum();
                }
                same
            }
            _ => false,
        };
        if let Some(e) = end {
            if !joined {
                start = pos;
            }
            pos = e;
        }
        if !joined {
            let mut c = c;
            if c.name == "ARC_FEED" {
                c.args[4] = c.args[4].signum();
            }
            out.push(c);
        }
    }
    out
}

fn same_call(a: &Call, b: &Call) -> bool {
    let motion = matches!(
        a.name.as_str(),
        "STRAIGHT_TRAVERSE" | "STRAIGHT_FEED" | "ARC_FEED"
    );
    if !motion {
        return a.name == b.name && a.text == b.text;
    }
    a.name == b.name
        && a.block == b.block
        && a.args.len() == b.args.len()
        && a.args
            .iter()
            .zip(&b.args)
            .all(|(x, y)| (x - y).abs() <= 1.5e-4 + 1e-9 * x.abs())
}

fn rs274() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("rs274"))
        .find(|p| p.is_file())
}

fn run_rs274(bin: &Path, home: &Path, file: &Path) -> String {
    let out = Command::new(bin)
        .env("HOME", home)
        .current_dir(home)
        .arg("-t")
        .arg(root().join("tests/nc/tools.tbl"))
        .arg("-g")
        .arg(file)
        .output()
        .expect("run rs274");
    assert!(
        out.status.success(),
        "rs274 refuses {}: {}",
        file.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn optimized_programs_keep_their_path_in_rs274() {
    let Some(bin) = rs274() else {
        skip_or_fail("rs274 (Debian linuxcnc-uspace) is not on PATH; install with .ci/deps");
        return;
    };
    let sc = scenario();
    let tmp = tempfile::tempdir().expect("temp dir");
    let mut checked = 0;
    let mut split_total = 0;
    for (file, stock) in present() {
        let path = build(&sc, &file, stock);
        let (out, opt) = optimized(&sc, &file, &path, tmp.path());
        let a = merged(parse(&run_rs274(&bin, tmp.path(), &file)));
        let b = merged(parse(&run_rs274(&bin, tmp.path(), &out)));
        let name = file.display();
        let first = a.iter().zip(&b).position(|(x, y)| !same_call(x, y));
        if let Some(k) = first {
            panic!(
                "{name}: call {k} differs after merging:\n original  {:?}\n optimized {:?}",
                a[k], b[k]
            );
        }
        assert_eq!(a.len(), b.len(), "{name}: calls after merging");
        // The optimized program really differs: F words rewritten (and blocks split).
        assert!(opt.lines_rewritten > 0, "{name}: nothing rewritten");
        println!(
            "{name}: {} calls agree; {} lines rewritten, {} split (+{} lines)",
            a.len(),
            opt.lines_rewritten,
            opt.lines_split,
            opt.lines_added
        );
        split_total += opt.lines_split;
        checked += 1;
    }
    assert!(checked >= 3, "only {checked} programs checked");
    assert!(split_total > 0, "no block was split on any program");
}

#[test]
fn optimized_programs_predict_at_most_fr_and_run_air_at_the_air_feed() {
    let sc = scenario();
    let params = PlanParams::of(&sc);
    let fr = params.force_ref_n;
    let tmp = tempfile::tempdir().expect("temp dir");
    for (file, stock) in present().into_iter().take(3) {
        let path = build(&sc, &file, stock);
        let (out, _) = optimized(&sc, &file, &path, tmp.path());
        let after = build(&sc, &out, stock);
        let before_peak = path
            .intervals(&params)
            .iter()
            .filter(|iv| !iv.rapid)
            .map(|iv| iv.f100)
            .fold(0.0, f64::max);
        let ivs = after.intervals(&params);
        let peak = ivs
            .iter()
            .filter(|iv| !iv.rapid)
            .map(|iv| iv.f100)
            .fold(0.0, f64::max);
        let name = file.display();
        assert!(
            before_peak > fr,
            "{name}: the original should overload ({before_peak:.0} N)"
        );
        println!(
            "{}: predicted peak at 100 % {:.3} Fr before, {:.3} Fr after",
            file.display(),
            before_peak / fr,
            peak / fr
        );
        assert!(
            peak <= 1.03 * fr && peak > 0.7 * fr,
            "{name}: optimized peak {peak:.0} N, Fr {fr} N"
        );
        // Air: a feed interval without force inside a block whose every interval is air
        // runs at the air feed (a plunge keeps its programmed feed).
        let air: Vec<_> = ivs
            .iter()
            .filter(|iv| !iv.rapid && iv.f100 <= 0.0)
            .collect();
        assert!(!air.is_empty(), "{name}: no air feed moves");
        let at_air = air
            .iter()
            .filter(|iv| (iv.feed - AIR_FEED).abs() < 0.1)
            .map(|iv| iv.b - iv.a)
            .sum::<f64>();
        let total = air.iter().map(|iv| iv.b - iv.a).sum::<f64>();
        assert!(
            at_air > 0.5 * total,
            "{name}: {at_air:.1} of {total:.1} mm of air at the air feed"
        );
    }
}

/// Block numbers (`BLOCK_NUMBER`: the N word, else the line number) that name motions of
/// more than one line of `file`.
fn shared_block_numbers(file: &Path) -> usize {
    let tbl = root().join("tests/nc/tools.tbl");
    let text = std::fs::read_to_string(&tbl).expect("tool table");
    let tools = acc_nc::ToolTable::parse_tbl("tools.tbl", &text, acc_nc::Units::Mm).expect("table");
    let setup = acc_nc::Setup {
        tools,
        ..acc_nc::Setup::default()
    };
    let prog = acc_nc::interpret_file(file, &setup).expect("interprets");
    acc_nc::shared_block_numbers(&prog.calls).len()
}

/// The program optimized: its added lines' numbers checked against every other block's.
fn numbers_checked(sc: &Scenario, file: &Path, stock: (&str, f64), dir: &Path) -> Optimized {
    let path = build(sc, file, stock);
    let (out, opt) = optimized(sc, file, &path, dir);
    let name = file.display();
    let (before, after) = (shared_block_numbers(file), shared_block_numbers(&out));
    println!(
        "{name}: {} lines added, numbered {:?}; block numbers naming more than one line: \
         {before} before, {after} after",
        opt.lines_added, opt.added_numbers
    );
    assert!(
        after <= before,
        "{name}: {after} block numbers shared, {before} before"
    );
    if let Some((a, b)) = opt.added_numbers {
        assert_eq!(
            (b - a + 1) as usize,
            opt.lines_added,
            "{name}: numbers used"
        );
    }
    opt
}

#[test]
fn the_added_lines_take_block_numbers_no_other_block_has() {
    let sc = scenario();
    let tmp = tempfile::tempdir().expect("temp dir");
    // N on every block (N0010 .. N0170): the added lines are numbered from N0171 on.
    let fanuc = root().join("tests/nc/fanuc_style.ngc");
    let opt = numbers_checked(&sc, &fanuc, ("20,-15,-10,70,60,0", 0.25), tmp.path());
    assert!(opt.lines_added > 0, "no block of fanuc_style.ngc was split");
    assert_eq!(opt.added_numbers.map(|r| r.0), Some(171));
    // Numbers past the board's 16-bit BLOCK_NUMBER are refused, naming the file and range.
    let high = tmp.path().join("fanuc_high.ngc");
    let text = std::fs::read_to_string(&fanuc).expect("program");
    std::fs::write(&high, text.replace("N0170 M30", "N65530 M30")).expect("write");
    let path = build(&sc, &high, ("20,-15,-10,70,60,0", 0.25));
    let params = OptimizeParams {
        plan: PlanParams::of(&sc),
        min_segment_mm: 1.0,
        max_feed_mm_min: sc.machine.feed_drive.rapid_mm_min,
    };
    let name = high.display().to_string();
    let err = optimize(
        &name,
        &text.replace("N0170 M30", "N65530 M30"),
        &path,
        &params,
        &|_| AIR_FEED,
    )
    .expect_err("numbers above 65535");
    let msg = err.to_string();
    assert!(
        msg.contains("fanuc_high.ngc") && msg.contains("N65531") && msg.contains("65535"),
        "{msg}"
    );
    for (file, stock) in present() {
        let opt = numbers_checked(&sc, &file, stock, tmp.path());
        let numbered = std::fs::read_to_string(&file)
            .expect("program")
            .lines()
            .any(|l| l.trim_start().starts_with('N'));
        assert_eq!(opt.added_numbers.is_some(), numbered && opt.lines_added > 0);
    }
}

#[test]
fn a_bad_minimum_segment_is_refused_with_its_range() {
    for bad in ["0", "-1", "nan"] {
        let arg = format!("--min-segment={bad}");
        let (ok, _, err) = acc_output(&[
            "optimize",
            "tests/nc/pocket_rect.ngc",
            "--stock-box=-20,-20,-10,60,50,0",
            &arg,
            "--out",
            "/nonexistent/never-written.ngc",
        ]);
        assert!(!ok, "--min-segment {bad} accepted");
        assert!(
            err.contains("--min-segment") && err.contains("0.01 ..= 1000 mm"),
            "{bad}: {err}"
        );
    }
}
