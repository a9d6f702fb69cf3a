//! `acc discrepancy --program` on a program whose lines run more than once
//! (`tests/nc/subroutine_passes.ngc`: one subroutine called for two passes, the second
//! deeper). A controller reports the same line numbers on both passes; each pass's rows
//! must be placed on its own visit of those lines. The log is `acc sim --program`'s, whose
//! rows carry the true path position (`x_true_mm`) and depth: the rebuilt positions and
//! depths of `rows.csv` are compared with them.

use std::collections::HashMap;

use crate::e2e_support::acc_output;

const PROGRAM: &str = "tests/nc/subroutine_passes.ngc";
const STOCK: &str = "--stock-box=0,-20,-10,60,20,0";

/// The CSV file's rows as column → value maps.
fn csv_rows(path: &std::path::Path) -> Vec<HashMap<String, String>> {
    let mut r = csv::Reader::from_path(path).expect("csv");
    let head: Vec<String> = r
        .headers()
        .expect("header")
        .iter()
        .map(String::from)
        .collect();
    r.records()
        .map(|rec| {
            let rec = rec.expect("row");
            head.iter()
                .cloned()
                .zip(rec.iter().map(String::from))
                .collect()
        })
        .collect()
}

fn num(row: &HashMap<String, String>, key: &str) -> f64 {
    row[key].parse().unwrap_or(0.0)
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
    let truth = csv_rows(&run);
    let rebuilt = csv_rows(&disc.join("rows.csv"));
    assert_eq!(truth.len(), rebuilt.len(), "one analysed row per log row");
    // The cutting rows of both passes: the first at 1 mm, the second at 3 mm deep. A row
    // whose period holds the entry may read the depth on either side of it.
    let mut per_depth = [0usize; 2];
    let mut off_depth = Vec::new();
    let mut worst_mm: f64 = 0.0;
    for (t, r) in truth.iter().zip(&rebuilt) {
        let depth = num(t, "axial_depth_mm");
        if num(t, "radial_depth_mm") <= 0.0 || depth <= 0.0 {
            continue;
        }
        let pass = usize::from(depth > 2.0);
        per_depth[pass] += 1;
        worst_mm = worst_mm.max((num(r, "x_mm") - num(t, "x_true_mm")).abs());
        if (num(r, "axial_mm") - depth).abs() > 0.05 {
            off_depth.push((t["t_s"].clone(), r["axial_mm"].clone(), depth));
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
