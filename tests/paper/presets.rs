//! The shipped presets load into the paper's configurations, and every invalid value is an
//! error naming the file, the key and the allowed range.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};

use acc_config::{load_preset, parse_preset, resolve_preset, ConfigError, RangeError};
use acc_core::{ControllerConfig, PaperCase};

fn presets_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/presets")
}

#[test]
fn shipped_presets_are_the_paper_cases() {
    for (file, case) in [
        ("fixed_gain.toml", PaperCase::FixedGain),
        ("case1.toml", PaperCase::I),
        ("case2.toml", PaperCase::II),
        ("case3.toml", PaperCase::III),
        ("case4.toml", PaperCase::IV),
    ] {
        let p = load_preset(presets_dir().join(file)).unwrap();
        assert_eq!(p.controller, ControllerConfig::paper_case(case), "{file}");
        assert_eq!(p.plant.kc_nominal, 4.0);
        assert_eq!(p.plant.nominal_feed_mm_min, 200.0);
        assert!(!p.name.is_empty() && !p.description.is_empty());
    }
}

#[test]
fn every_key_of_a_preset_is_documented_in_a_comment() {
    for entry in std::fs::read_dir(presets_dir()).unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            let l = line.trim();
            if l.is_empty() || l.starts_with('#') || l.starts_with('[') {
                continue;
            }
            assert!(
                i > 0 && lines[i - 1].trim().starts_with('#'),
                "{}:{}: key without a comment above: {l}",
                path.display(),
                i + 1
            );
        }
    }
}

fn case1_text() -> String {
    std::fs::read_to_string(presets_dir().join("case1.toml")).unwrap()
}

/// Replace the first line starting with `key =` by `key = value`.
fn with(text: &str, key: &str, value: &str) -> String {
    let mut done = false;
    text.lines()
        .map(|l| {
            if !done && l.starts_with(&format!("{key} =")) {
                done = true;
                format!("{key} = {value}")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn out_of_range(text: &str) -> (String, String, String) {
    match parse_preset("presets/bad.toml", text).unwrap_err() {
        ConfigError::OutOfRange(RangeError {
            file,
            key,
            allowed,
            value,
        }) => {
            assert_eq!(file, Some(PathBuf::from("presets/bad.toml")));
            (key, allowed, value)
        }
        other => panic!("expected OutOfRange, got {other:?}"),
    }
}

#[test]
fn invalid_values_name_file_key_and_range() {
    let base = case1_text();
    for (key, value, want_key, want_allowed) in [
        ("period_s", "0.0", "controller.period_s", "0.001 ..= 10"),
        (
            "force_ref_n",
            "-800.0",
            "controller.force_ref_n",
            "1 ..= 100000",
        ),
        ("km", "0.0", "controller.km", "0 < x < 1000000"),
        (
            "poles",
            "[0.5, 1.0]",
            "mode.poles",
            "|z| < 1 (strictly inside the unit circle)",
        ),
        (
            "poles",
            "{ re = 0.8, im = 0.7 }",
            "mode.poles",
            "|z| < 1 (strictly inside the unit circle)",
        ),
        ("step_pct", "0", "override.step_pct", "1 ..= 50"),
        (
            "max_pct",
            "160",
            "override.max_pct",
            "a multiple of step_pct = 10, <= 150",
        ),
        (
            "min_pct",
            "5",
            "override.min_pct",
            "a multiple of step_pct = 10, <= max_pct = 150",
        ),
        (
            "hysteresis_pct",
            "5.5",
            "override.hysteresis_pct",
            "0 ..= 5",
        ),
        (
            "hysteresis_pct",
            "-1.0",
            "override.hysteresis_pct",
            "0 ..= 5",
        ),
        (
            "kc_initial",
            "200.0",
            "estimator.kc_initial",
            "0.05 ..= 100",
        ),
        ("kc_min", "-1.0", "estimator.kc_min", "0 < x < 10000"),
        (
            "kc_max",
            "0.01",
            "estimator.kc_max",
            "kc_min = 0.05 < x <= 10000",
        ),
        ("mu", "2.0", "estimator.mu", "0 < x < 2"),
        (
            "min_force_n",
            "-1.0",
            "estimator.min_force_n",
            "0 ..= 100000",
        ),
        (
            "min_feed_mm_min",
            "nan",
            "estimator.min_feed_mm_min",
            "0 ..= 100000",
        ),
        (
            "confirm_periods",
            "20000",
            "estimator.confirm_periods",
            "0 ..= 10000",
        ),
        ("confirm_tol", "1.5", "estimator.confirm_tol", "0 < x < 1"),
        ("kc_nominal", "0.0", "plant.kc_nominal", "0 < x < 10000"),
        (
            "kc_sweep",
            "[5.0, 1.0]",
            "plant.kc_sweep[1]",
            "kc_sweep[0] = 5 < x <= 10000",
        ),
    ] {
        let (k, allowed, _) = out_of_range(&with(&base, key, value));
        assert_eq!(
            (k.as_str(), allowed.as_str()),
            (want_key, want_allowed),
            "{key} = {value}"
        );
    }
    let err = parse_preset("presets/bad.toml", &with(&base, "poles", "[0.5, 1.0]")).unwrap_err();
    assert_eq!(
        err.to_string(),
        "presets/bad.toml: key `mode.poles` = [0.5, 1] (desired pole has magnitude 1, on or \
         outside the unit circle: poles must satisfy |z| < 1) is out of range: allowed |z| < 1 \
         (strictly inside the unit circle)"
    );
}

#[test]
fn fixed_gain_and_integral_modes_are_checked() {
    let fixed = std::fs::read_to_string(presets_dir().join("fixed_gain.toml")).unwrap();
    assert_eq!(out_of_range(&with(&fixed, "ki", "0.0")).0, "mode.ki");
    assert_eq!(out_of_range(&with(&fixed, "kp", "-0.05")).0, "mode.kp");
    let integral =
        with(&case1_text(), "kind", "\"adaptive-i\"").replace("poles = [0.2, -0.05]", "pole = 0.5");
    let p = parse_preset("i.toml", &integral).unwrap();
    assert_eq!(
        p.controller.mode,
        acc_core::ModeConfig::AdaptiveIntegral { pole: 0.5 }
    );
    assert_eq!(
        out_of_range(&with(&integral, "pole", "-1.0")).0,
        "mode.pole"
    );
}

#[test]
fn structural_errors_name_the_key() {
    let base = case1_text();
    // Unknown key.
    let err = parse_preset(
        "x.toml",
        &base.replace("km = 1.0", "km = 1.0\nkm_typo = 2.0"),
    )
    .unwrap_err();
    // …named with its table and the nearest known key.
    assert!(
        matches!(&err, ConfigError::Invalid { key, .. } if key == "controller.km_typo"),
        "{err:?}"
    );
    assert!(
        err.to_string()
            .contains("allowed keys in `controller`: period_s, force_ref_n, km,"),
        "{err}"
    );
    // Missing key.
    let err = parse_preset("x.toml", &base.replace("period_s = 0.1", "")).unwrap_err();
    assert!(
        err.to_string()
            .contains("key `controller.period_s`: missing"),
        "{err}"
    );
    // Fixed gain without g_c.
    let err = parse_preset("x.toml", &with(&base, "gain", "\"fixed\"")).unwrap_err();
    assert_eq!(
        err,
        ConfigError::Invalid {
            file: "x.toml".into(),
            key: "estimator.g_c".into(),
            message: "required when gain = \"fixed\"".into()
        }
    );
    // Malformed poles: the message names the key and both accepted forms.
    for bad in [
        "[0.5]",
        "[0.5, 0.1, 0.2]",
        "{ re = 0.5, imm = 0.1 }",
        "\"0.5\"",
        "[0.5, \"x\"]",
    ] {
        let err = parse_preset("x.toml", &with(&base, "poles", bad)).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("x.toml") && msg.contains("mode.poles") && msg.contains("[z1, z2]"),
            "{bad}: {msg}"
        );
    }
    // Integer poles are numbers too.
    let p = parse_preset("x.toml", &with(&base, "poles", "[0, 0]")).unwrap();
    assert_eq!(
        p.controller.mode,
        acc_core::ModeConfig::AdaptivePi {
            poles: acc_core::DesiredPoles::Real(0.0, 0.0)
        }
    );
    // Unknown mode kind.
    let err = parse_preset("x.toml", &with(&base, "kind", "\"bang-bang\"")).unwrap_err();
    assert!(err.to_string().contains("bang-bang"), "{err}");
    // Missing file.
    let err = load_preset("no/such/preset.toml").unwrap_err();
    assert!(matches!(err, ConfigError::Io { .. }), "{err}");
}

#[test]
fn preset_names_resolve_in_the_presets_dir() {
    assert_eq!(
        resolve_preset("case1", "configs/presets"),
        PathBuf::from("configs/presets/case1.toml")
    );
    assert_eq!(
        resolve_preset("my/own.toml", "configs/presets"),
        PathBuf::from("my/own.toml")
    );
}

#[test]
fn override_hysteresis_is_optional_and_read() {
    let base = case1_text();
    let p = parse_preset("h.toml", &with(&base, "hysteresis_pct", "4.0")).unwrap();
    assert_eq!(p.controller.override_spec.hysteresis_pct, 4.0);
    let without: String = base
        .lines()
        .filter(|l| !l.starts_with("hysteresis_pct"))
        .collect::<Vec<_>>()
        .join("\n");
    assert_ne!(without, base);
    let p = parse_preset("h.toml", &without).unwrap();
    assert_eq!(p.controller, ControllerConfig::paper_case(PaperCase::I));
    // Half of a 1 % step is the largest accepted value on a byte board.
    let byte = with(
        &with(&with(&base, "step_pct", "1"), "hysteresis_pct", "0.6"),
        "min_pct",
        "0",
    );
    let (key, allowed, value) = out_of_range(&byte);
    assert_eq!(
        (key.as_str(), allowed.as_str(), value.as_str()),
        ("override.hysteresis_pct", "0 ..= 0.5", "0.6")
    );
}
