//! The plan learns from the log (`acc plan --model`): a part cut by a wearing tool
//! (`acc sim --program`), `acc discrepancy` on its log names the wear and writes the updated
//! model, and the next part's plan from that model predicts the force the next part shows
//! far better than the plan from the nominal scenario (`acc plan --measured`). A model file
//! out of range is refused naming the file and the key.

use crate::e2e_support::{acc_output, root};

/// The program, its stock (14.3 cm³ removed) and the wearing tool's scenario (dynamometer,
/// +1.5 % Ks per cm³: +21 % over the part).
const PROGRAM: &str = "tests/nc/contour_inside_corners.ngc";
const STOCK: &str = "--stock-box=-10,-10,-10,70,65,0";
const SCENARIO: &str = "configs/scenarios/tool_wear_dynamometer.toml";
/// The tool's true wear growth, 1/cm³ (the scenario's `[wear]`).
const TRUE_GROWTH: f64 = 0.015;
/// The volume the program removes, cm³.
const PART_CM3: f64 = 14.3;

fn acc(args: &[&str]) -> String {
    let (ok, out, err) = acc_output(args);
    assert!(ok, "acc {args:?} failed:\n{out}\n{err}");
    out
}

/// One part on the wearing tool (a new tool of the same kind), its run log.
fn part(dir: &std::path::Path, name: &str, seed: &str) -> String {
    let out = dir.join(name);
    acc(&[
        "sim",
        SCENARIO,
        "--program",
        PROGRAM,
        STOCK,
        "--seed",
        seed,
        "--no-plot",
        "--out",
        &out.display().to_string(),
    ]);
    out.join("run.csv").display().to_string()
}

/// The RMS (N) of `acc plan --measured`'s force error line.
pub(crate) fn plan_rms(stdout: &str) -> f64 {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("plan's force error against"))
        .unwrap_or_else(|| panic!("no force error line:\n{stdout}"));
    line.split("RMS ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no RMS in `{line}`"))
}

#[test]
fn the_plan_from_the_updated_model_predicts_the_next_part() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let dir = tmp.path();
    let first = part(dir, "part1", "8");
    let disc = dir.join("disc");
    let said = acc(&[
        "discrepancy",
        "--model",
        "configs/models/paper_vmc.toml",
        "--measured",
        &first,
        "--out",
        &disc.display().to_string(),
    ]);
    let report = std::fs::read_to_string(disc.join("report.json")).expect("report.json");
    let report: serde_json::Value = serde_json::from_str(&report).expect("json");
    let named: Vec<&str> = report["accepted"]
        .as_array()
        .expect("accepted")
        .iter()
        .filter_map(|v| v.as_str())
        .collect();
    assert!(named.contains(&"tool_wear"), "named {named:?}: {said}");
    let updated = disc.join("model.updated.toml");
    let model = acc_ident::Model::load(&updated).expect("updated model");
    // The learned law (growth and volume exponent) gives the part's wear within 25 %.
    let rise = model.tool.wear.factor(PART_CM3, 0.0) - 1.0;
    let true_rise = TRUE_GROWTH * PART_CM3;
    assert!(
        (rise - true_rise).abs() < 0.25 * true_rise,
        "learned wear over the part {rise:.3}, true {true_rise:.3}: {:?}",
        model.tool.wear
    );

    let next = part(dir, "part2", "9");
    let plan = |extra: &[&str], out: &str| {
        let out = dir.join(out).display().to_string();
        let mut args = vec![
            "plan",
            PROGRAM,
            STOCK,
            "--no-plot",
            "--measured",
            &next,
            "--out",
            &out,
        ];
        args.extend_from_slice(extra);
        let stdout = acc(&args);
        let csv = std::fs::read_to_string(format!("{out}/plan.csv")).expect("plan.csv");
        (plan_rms(&stdout), stdout, csv)
    };
    let (before, said0, csv0) = plan(&[], "plan-nominal");
    let model_arg = updated.display().to_string();
    let (after, said1, csv1) = plan(&["--model", &model_arg], "plan-model");
    assert!(said0.contains("force predicted by scenario"), "{said0}");
    assert!(
        csv0.starts_with("block,"),
        "the nominal plan file is unchanged"
    );
    assert!(
        said1.contains("force predicted by model") && said1.contains("model.updated.toml"),
        "{said1}"
    );
    assert!(
        csv1.starts_with("# force predicted by model") && csv1.contains("tool wear: Ks factor"),
        "{}",
        csv1.lines().next().unwrap_or("")
    );
    // The wear is visible: the nominal plan misses the next part's force by more than
    // 2 % of Fr (800 N) in RMS; the learned plan by less than half of that.
    assert!(before > 16.0, "nominal plan error {before} N");
    assert!(
        after < 0.5 * before,
        "plan error {before:.1} N → {after:.1} N\n{said1}"
    );
    // The plan file with its note is the one `acc sim --plan` reads.
    let (ok, out, err) = acc_output(&[
        "sim",
        SCENARIO,
        "--program",
        PROGRAM,
        STOCK,
        "--no-plot",
        "--plan",
        &dir.join("plan-model/plan.csv").display().to_string(),
        "--out",
        &dir.join("part3").display().to_string(),
    ]);
    assert!(ok, "{out}\n{err}");
}

#[test]
fn a_model_out_of_range_is_refused_naming_the_file_and_key() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let text = std::fs::read_to_string(root().join("configs/models/paper_vmc.toml"))
        .expect("model")
        .replace("growth_per_cm3 = 0.0", "growth_per_cm3 = -1.0");
    let bad = tmp.path().join("bad_model.toml");
    std::fs::write(&bad, text).expect("write");
    let out = tmp.path().join("plan");
    let (ok, _, err) = acc_output(&[
        "plan",
        PROGRAM,
        STOCK,
        "--no-plot",
        "--model",
        &bad.display().to_string(),
        "--out",
        &out.display().to_string(),
    ]);
    assert!(!ok, "refused");
    assert!(
        err.contains("bad_model.toml") && err.contains("tool.wear.growth_per_cm3"),
        "{err}"
    );
    assert!(!out.join("plan.csv").exists(), "nothing written");
}
