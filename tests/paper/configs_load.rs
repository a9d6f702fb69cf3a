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

/// Dotted keys of every number in a TOML table (arrays are not walked).
fn numeric_keys(prefix: &str, t: &toml::Table, out: &mut Vec<String>) {
    for (k, v) in t {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Integer(_) | toml::Value::Float(_) => out.push(key),
            toml::Value::Table(inner) => numeric_keys(&key, inner, out),
            _ => {}
        }
    }
}

#[test]
fn every_numeric_key_of_the_shipped_run_configs_and_presets_has_a_listed_range() {
    let listed = |ranges: &[acc_config::KeyRange], key: &str| ranges.iter().any(|r| r.key == key);
    for (dir, ranges) in [
        ("runtime", acc_runtime::config::RUN_KEY_RANGES),
        ("presets", acc_config::preset::PRESET_KEY_RANGES),
    ] {
        for p in files(dir) {
            let text = std::fs::read_to_string(&p).expect("readable");
            let table: toml::Table = toml::from_str(&text).expect("toml");
            // Run configs only (the calibration beside them has its own checks).
            if dir == "runtime" && !table.contains_key("controller") {
                continue;
            }
            let mut keys = Vec::new();
            numeric_keys("", &table, &mut keys);
            for k in keys {
                assert!(
                    listed(ranges, &k),
                    "{}: numeric key `{k}` has no allowed range listed",
                    p.display()
                );
            }
        }
    }
}

/// The listed `lo ..= hi` ranges of the run config agree with its validation: both ends load,
/// one step outside either end is refused with an error naming the key.
#[test]
fn the_listed_run_config_ranges_agree_with_the_validation() {
    let base_path = acc_sim::run::configs_dir().join("runtime/board_sim_fast.toml");
    let cfg = acc_sim::run::configs_dir();
    // The edited copies live in a temp folder: the relative paths made absolute.
    let base = std::fs::read_to_string(&base_path)
        .expect("base")
        .replace("\"../presets/", &format!("\"{}/presets/", cfg.display()))
        .replace(
            "\"paper_vmc_power.toml\"",
            &format!("\"{}/runtime/paper_vmc_power.toml\"", cfg.display()),
        );
    let dir = tempfile::tempdir().expect("temp dir");
    let mut probed = 0;
    for r in acc_runtime::config::RUN_KEY_RANGES {
        let Some((lo, hi)) = r.allowed.split_once(" ..= ") else {
            continue;
        };
        let (Ok(lo), Ok(hi)) = (lo.trim().parse::<f64>(), hi.trim().parse::<f64>()) else {
            continue;
        };
        let (table, key) = r.key.rsplit_once('.').expect("dotted");
        let can = table == "can";
        let integer = !r.key.ends_with("_s")
            && !r.key.contains("time_scale")
            && !r.key.contains("radius")
            && !r.key.contains("sigma")
            && !r.key.contains("speed_change")
            && !r.key.contains("rpm")
            && !r.key.ends_with("_n");
        let fmt = |v: f64| {
            if integer {
                format!("{}", v as i64)
            } else {
                format!("{v:?}")
            }
        };
        let step = if integer { 1.0 } else { (hi - lo).abs() * 1e-3 };
        for (value, ok) in [
            (lo, true),
            (hi, true),
            (lo - step, false),
            (hi + step, false),
        ] {
            let text = set_key(&base, table, key, &fmt(value));
            let path = dir.path().join(format!("probe-{probed}.toml"));
            std::fs::write(&path, &text).expect("write");
            let res = acc_runtime::config::RunConfig::load_for(&path, None, can.then_some("vcan0"));
            let names_key = match &res {
                Err(e) => e.to_string().contains(&format!("`{}`", r.key)),
                Ok(_) => false,
            };
            if ok {
                assert!(
                    !names_key,
                    "{} = {} is allowed ({}): {res:?}",
                    r.key,
                    fmt(value),
                    r.allowed
                );
            } else {
                assert!(
                    names_key,
                    "{} = {} is outside {}: {res:?}",
                    r.key,
                    fmt(value),
                    r.allowed
                );
            }
            probed += 1;
        }
    }
    assert!(probed >= 60, "{probed} probes");
}

/// `text` with `key = value` in `[table]` (replaced, or added with the table).
fn set_key(text: &str, table: &str, key: &str, value: &str) -> String {
    let mut out = Vec::new();
    let mut current = String::new();
    let mut done = false;
    for line in text.lines() {
        if line.starts_with('[') {
            if !done && current == table {
                out.push(format!("{key} = {value}"));
                done = true;
            }
            current = line.trim().trim_matches(['[', ']']).to_string();
        }
        if !done && current == table && line.starts_with(&format!("{key} =")) {
            out.push(format!("{key} = {value}"));
            done = true;
            continue;
        }
        out.push(line.to_string());
    }
    if !done {
        if current != table {
            out.push(format!("[{table}]"));
        }
        out.push(format!("{key} = {value}"));
    }
    out.join("\n") + "\n"
}
