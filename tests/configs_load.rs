//! Every shipped scenario, model, run config and controller preset loads: a broken key or range in `configs/` fails
//! here with the file named, not at a user's machine.

use std::path::PathBuf;

fn files(dir: &str) -> Vec<PathBuf> {
    let dir = acc_sim::run::configs_dir().join(dir);
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    v.sort();
    v
}

#[test]
fn every_scenario_loads() {
    let all = files("scenarios");
    assert!(all.len() >= 12, "{} scenarios", all.len());
    for p in all {
        if let Err(e) = acc_sim::scenario::Scenario::load(&p) {
            panic!("{}: {e:#}", p.display());
        }
    }
}

#[test]
fn every_model_loads() {
    let all = files("models");
    assert!(!all.is_empty());
    for p in all {
        if let Err(e) = acc_ident::Model::load(&p) {
            panic!("{}: {e:#}", p.display());
        }
    }
}

#[test]
fn every_run_config_and_preset_loads() {
    let runs: Vec<PathBuf> = files("runtime")
        .into_iter()
        .filter(|p| {
            std::fs::read_to_string(p).is_ok_and(|t| t.lines().any(|l| l.starts_with("controller")))
        })
        .collect();
    assert!(runs.len() >= 4, "{} run configs", runs.len());
    for p in runs {
        if let Err(e) = acc_runtime::config::RunConfig::load(&p, None) {
            panic!("{}: {e:#}", p.display());
        }
    }
    let presets = files("presets");
    assert!(presets.len() >= 5);
    for p in presets {
        if let Err(e) = acc_config::load_preset(&p) {
            panic!("{}: {e:#}", p.display());
        }
    }
}
