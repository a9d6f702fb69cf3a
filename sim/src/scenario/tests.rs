//! Scenario loading and validation.

use super::*;

/// Write `tool_wear.toml` with its `machine`/`tool` lines replaced by `keys` into a temp
/// dir next to absolute paths of the other files; returns the dir and the scenario path.
fn scenario_with(keys: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("temp dir");
    let cfg = crate::run::configs_dir();
    let c = |rel: &str| cfg.join(rel).display().to_string();
    let text = format!(
        "name = \"t\"\n{keys}\nworkpiece = '{}'\ncontroller = '{}'\nseed = 1\nprogrammed_feed_mm_min = 200.0\n",
        c("workpieces/long_cut.toml"),
        c("presets/case3.toml")
    );
    let path = dir.path().join("s.toml");
    std::fs::write(&path, text).expect("write scenario");
    (dir, path)
}

fn key_of(e: &ConfigError) -> &str {
    match e {
        ConfigError::Invalid { key, .. }
        | ConfigError::OutOfRange(acc_config::RangeError { key, .. }) => key,
        other => panic!("expected a keyed error, got {other}"),
    }
}

#[test]
fn model_key_gives_the_same_machine_and_tool_as_the_two_files() {
    let cfg = crate::run::configs_dir();
    let (_d1, files) = scenario_with(&format!(
        "machine = '{}'\ntool = '{}'",
        cfg.join("machines/paper_vmc.toml").display(),
        cfg.join("machines/tools/hss_endmill_16_4f.toml").display()
    ));
    let (_d2, model) = scenario_with(&format!(
        "model = '{}'",
        cfg.join("models/paper_vmc.toml").display()
    ));
    let a = Scenario::load(&files).expect("machine + tool load");
    let b = Scenario::load(&model).expect("model loads");
    assert_eq!(a.machine.spindle, b.machine.spindle);
    assert_eq!(a.machine.feed_drive, b.machine.feed_drive);
    assert_eq!(a.machine.override_path, b.machine.override_path);
    assert_eq!(a.tool.process, b.tool.process);
    assert_eq!(a.tool.diameter_mm, b.tool.diameter_mm);
    assert_eq!(b.wear, b.tool.wear);
}

#[test]
fn both_forms_neither_or_half_are_errors_naming_the_key() {
    let cfg = crate::run::configs_dir();
    let m = cfg.join("machines/paper_vmc.toml").display().to_string();
    let t = cfg
        .join("machines/tools/hss_endmill_16_4f.toml")
        .display()
        .to_string();
    let md = cfg.join("models/paper_vmc.toml").display().to_string();
    let cases = [
        (
            format!("machine = '{m}'\ntool = '{t}'\nmodel = '{md}'"),
            "model",
            "not both",
        ),
        (format!("model = '{md}'\ntool = '{t}'"), "model", "not both"),
        (String::new(), "machine", "`model`"),
        (format!("tool = '{t}'"), "machine", "missing"),
        (format!("machine = '{m}'"), "tool", "missing"),
    ];
    for (keys, key, words) in cases {
        let (_d, path) = scenario_with(&keys);
        let e = Scenario::load(&path).expect_err(&keys);
        assert_eq!(key_of(&e), key, "{keys}: {e}");
        let text = e.to_string();
        assert!(
            text.contains("s.toml") && text.contains(words),
            "{keys}: {text}"
        );
    }
}

#[test]
fn missing_or_bad_model_file_names_the_file_and_key() {
    let (dir, path) = scenario_with("model = 'no_such_model.toml'");
    let e = Scenario::load(&path).expect_err("missing model file");
    assert_eq!(key_of(&e), "model");
    assert!(e.to_string().contains("no_such_model.toml"), "{e}");

    // A value out of range inside the model file: the model file and the dotted key.
    let good = std::fs::read_to_string(crate::run::configs_dir().join("models/paper_vmc.toml"))
        .expect("model file");
    let bad = good.replace("tau_s = 0.008", "tau_s = 5.0");
    assert_ne!(bad, good);
    std::fs::write(dir.path().join("no_such_model.toml"), bad).expect("write model");
    let e = Scenario::load(&path).expect_err("bad model file");
    assert_eq!(key_of(&e), "machine.feed_drive.tau_s", "{e}");
    assert!(e.to_string().contains("no_such_model.toml"), "{e}");
}

#[test]
fn use_model_replaces_machine_tool_and_wear() {
    let cfg = crate::run::configs_dir();
    let mut sc = Scenario::load(cfg.join("scenarios/tool_wear.toml")).expect("scenario");
    assert!(sc.wear.growth_per_cm3 > 0.0, "the scenario's [wear] is on");
    let model = cfg.join("models/paper_vmc.toml");
    sc.use_model(&model).expect("model applies");
    assert_eq!(
        sc.wear.growth_per_cm3, 0.0,
        "the model's (wear-free) tool wins"
    );
    assert_eq!(sc.machine.feed_drive.tau_s, 0.008);

    let dir = tempfile::tempdir().expect("temp dir");
    let small = dir.path().join("m.toml");
    let text = std::fs::read_to_string(&model)
        .expect("model file")
        .replace("diameter_mm = 16.0", "diameter_mm = 2.0");
    std::fs::write(&small, text).expect("write model");
    let e = sc.use_model(&small).expect_err("tool smaller than the cut");
    assert_eq!(key_of(&e), "tool.diameter_mm", "{e}");
}
