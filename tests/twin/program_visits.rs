//! `acc discrepancy --program` on a program whose lines run more than once
//! (`tests/nc/subroutine_passes.ngc`: one subroutine called for two passes, the second
//! deeper). A controller reports the same line numbers on both passes; each pass's rows
//! must be placed on its own visit of those lines. The log is `acc sim --program`'s, whose
//! rows carry the true path position (`x_true_mm`) and depth: the rebuilt positions and
//! depths of `rows.csv` are compared with them.

use std::path::Path;

use crate::e2e_support::{acc_output, read_log};

const PROGRAM: &str = "tests/nc/subroutine_passes.ngc";
const STOCK: &str = "--stock-box=0,-20,-10,60,20,0";

/// The rebuilt path position and axial depth of every row of `acc discrepancy`'s
/// `rows.csv`, mm.
fn rebuilt_rows(path: &Path) -> Vec<(f64, f64)> {
    let mut r = csv::Reader::from_path(path).expect("rows.csv");
    let head = r.headers().expect("header").clone();
    let col = |name: &str| head.iter().position(|h| h == name).expect(name);
    let (x, axial) = (col("x_mm"), col("axial_mm"));
    r.records()
        .map(|rec| {
            let rec = rec.expect("row");
            let num = |i: usize| rec[i].parse::<f64>().expect("a number");
            (num(x), num(axial))
        })
        .collect()
}

#[test]
fn each_pass_of_a_subroutine_is_placed_on_its_own_visit() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let sim = tmp.path().join("sim");
    let disc = tmp.path().join("disc");
    let (ok, out, err) = acc_output(&[
        "sim",
        "configs/scenarios/paper_case3.toml",
        "--program",
        PROGRAM,
        STOCK,
        "--no-plot",
        "--out",
        &sim.display().to_string(),
    ]);
    assert!(ok, "acc sim: {out}\n{err}");
    let run = sim.join("run.csv");
    let (ok, out, err) = acc_output(&[
        "discrepancy",
        "--model",
        "configs/models/paper_vmc.toml",
        "--measured",
        &run.display().to_string(),
        "--program",
        PROGRAM,
        STOCK,
        "--out",
        &disc.display().to_string(),
    ]);
    assert!(ok, "acc discrepancy --program: {out}\n{err}");
    let truth = read_log(&run);
    let rebuilt = rebuilt_rows(&disc.join("rows.csv"));
    assert_eq!(truth.len(), rebuilt.len(), "one analysed row per log row");
    // The cutting rows of both passes: the first at 1 mm, the second at 3 mm deep. A row
    // whose period holds the entry may read the depth on either side of it.
    let mut per_depth = [0usize; 2];
    let mut off_depth = Vec::new();
    let mut worst_mm: f64 = 0.0;
    for (t, &(x_mm, axial_mm)) in truth.iter().zip(&rebuilt) {
        let (Some(radial), Some(depth), Some(x_true)) =
            (t.radial_depth_mm, t.axial_depth_mm, t.x_true_mm)
        else {
            continue;
        };
        if radial <= 0.0 || depth <= 0.0 {
            continue;
        }
        per_depth[usize::from(depth > 2.0)] += 1;
        worst_mm = worst_mm.max((x_mm - x_true).abs());
        if (axial_mm - depth).abs() > 0.05 {
            off_depth.push((t.t_s, axial_mm, depth));
        }
    }
    let cutting = per_depth[0] + per_depth[1];
    assert!(
        off_depth.len() * 20 <= cutting,
        "{} of {cutting} cutting rows at another depth than the true one (t, rebuilt, true): {off_depth:?}",
        off_depth.len()
    );
    assert!(
        per_depth.iter().all(|&n| n > 20),
        "cutting rows per pass: {per_depth:?}"
    );
    // The rebuild places a block's first row half a period past the block's start; the
    // simulator's `x_true_mm` is the plant's position two periods' travel further (1.5 mm
    // at 450 mm/min: a constant offset along both passes). Placed on the first pass's
    // visit, the second pass's rows were 147 mm off.
    assert!(
        worst_mm < 2.0,
        "rebuilt path position off the true one by {worst_mm:.2} mm"
    );
}
