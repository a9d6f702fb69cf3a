//! Override resolution end to end: the production loop (`ControlLoop` + `FaultPolicy`)
//! against the simulated board (the emulator's register logic, which refuses a command off
//! its `OVERRIDE_STEP` grid) on a 10 % and a 1 % board, with the plain rounding and the
//! σ-Δ quantizer; and the preset key `[override] quantizer`.

use acc_core::{OverrideSpec, Quantizer};
use acc_sim::run::configs_dir;
use acc_sim::{LawKind, Scenario};

fn case3(board_step: u16, preset: OverrideSpec) -> Scenario {
    let mut sc = Scenario::load(configs_dir().join("scenarios/paper_case3.toml")).expect("load");
    sc.machine.override_path.step_pct = board_step;
    sc.controller.override_spec = preset;
    sc
}

/// Every written and applied override is on the board's grid and in range, the run
/// finishes, and in every cut section that can reach Fr the settled mean force is within
/// 1 % of Fr.
fn check(board_step: u16, preset: OverrideSpec) {
    let sc = case3(board_step, preset);
    let (r, s) = sc.run_law(LawKind::Ours).expect("run");
    let tag = format!(
        "board {board_step} %, preset step {} %, {:?}",
        preset.step_pct, preset.quantizer
    );
    assert!(r.finished, "{tag}: unfinished");
    assert!(s.cycle_time_s.is_some(), "{tag}");
    let mut written = 0;
    for row in &r.rows {
        if let Some(c) = row.override_cmd_pct {
            written += 1;
            assert!(c <= 150 && c % preset.step_pct == 0, "{tag}: wrote {c}");
        }
        if let Some(a) = row.override_applied_pct {
            assert!(a <= 150 && a % board_step == 0, "{tag}: applied {a}");
        }
        assert!(!row.flags.contains("exception"), "{tag}: {}", row.flags);
    }
    assert!(written > 400, "{tag}: {written} writes");
    let mut cuts = 0;
    for g in s.segments.iter().filter(|g| g.is_cut && g.reaches_ref) {
        cuts += 1;
        assert!(
            g.mean_error_n.abs() <= 0.01 * s.force_ref_n,
            "{tag}: {} settled mean error {:.1} N",
            g.label,
            g.mean_error_n
        );
    }
    assert_eq!(cuts, 3, "{tag}: the 2, 3 and 4 mm sections all regulate");
}

#[test]
fn ten_percent_board_round_and_sigma_delta() {
    check(10, OverrideSpec::paper());
    check(
        10,
        OverrideSpec::paper().with_quantizer(Quantizer::SigmaDelta),
    );
}

#[test]
fn one_percent_board_round_and_sigma_delta() {
    check(1, OverrideSpec::byte_board());
    check(
        1,
        OverrideSpec::byte_board().with_quantizer(Quantizer::SigmaDelta),
    );
    // A 10 % preset on a 1 % board keeps its own (coarser) grid.
    check(
        1,
        OverrideSpec::paper().with_quantizer(Quantizer::SigmaDelta),
    );
}

/// A 1 % preset on a 10 % board is refused at load, naming the key.
#[test]
fn finer_preset_than_the_board_is_refused() {
    let dir = tempfile::tempdir().expect("tmp");
    let preset = std::fs::read_to_string(configs_dir().join("presets/case3.toml"))
        .expect("preset")
        .replace("step_pct = 10", "step_pct = 1");
    std::fs::write(dir.path().join("p.toml"), preset).expect("write");
    let sc = std::fs::read_to_string(configs_dir().join("scenarios/paper_case3.toml"))
        .expect("scenario")
        .replace("../presets/case3.toml", "p.toml")
        .replace("\"../", &format!("\"{}/", configs_dir().display()));
    std::fs::write(dir.path().join("s.toml"), sc).expect("write");
    let e = Scenario::load(dir.path().join("s.toml")).expect_err("1 % preset on a 10 % board");
    let msg = e.to_string();
    assert!(
        msg.contains("controller") && msg.contains("board step"),
        "{msg}"
    );
}

/// `[override] quantizer`: "sigma_delta" loads; an unknown name and a hysteresis with
/// σ-Δ are refused naming the file, the key and the allowed values.
#[test]
fn preset_quantizer_key() {
    let dir = tempfile::tempdir().expect("tmp");
    let base = std::fs::read_to_string(configs_dir().join("presets/case3.toml")).expect("preset");
    assert!(
        base.contains("quantizer = \"round\""),
        "case3 names its quantizer"
    );
    let write = |name: &str, text: String| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).expect("write");
        p
    };
    let ok = write(
        "sd.toml",
        base.replace("quantizer = \"round\"", "quantizer = \"sigma_delta\""),
    );
    let c = acc_config::load_controller(&ok).expect("sigma_delta preset");
    assert_eq!(c.override_spec.quantizer, Quantizer::SigmaDelta);
    let unknown = write(
        "bad.toml",
        base.replace("quantizer = \"round\"", "quantizer = \"dither\""),
    );
    let msg = acc_config::load_controller(&unknown)
        .expect_err("unknown")
        .to_string();
    assert!(
        msg.contains("bad.toml") && msg.contains("quantizer") && msg.contains("dither"),
        "{msg}"
    );
    assert!(msg.contains("sigma_delta"), "allowed values named: {msg}");
    let both = write(
        "both.toml",
        base.replace("quantizer = \"round\"", "quantizer = \"sigma_delta\"")
            .replace("hysteresis_pct = 0.0", "hysteresis_pct = 2.0"),
    );
    let msg = acc_config::load_controller(&both)
        .expect_err("both")
        .to_string();
    assert!(
        msg.contains("both.toml")
            && msg.contains("override.hysteresis_pct")
            && msg.contains("sigma_delta"),
        "{msg}"
    );
}
