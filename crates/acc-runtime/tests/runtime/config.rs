//! The shipped run configs load and validate; bad values name the file and the key.

use std::path::PathBuf;

use acc_runtime::config::{LinkSettings, RunConfig};

fn cfg(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../configs/runtime")
        .join(name)
}

#[test]
fn shipped_run_configs_load() {
    for name in [
        "paper_vmc_run.toml",
        "board_sim_fast.toml",
        "board_sim_faults.toml",
    ] {
        let c = RunConfig::load(cfg(name), None).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!((c.controller.period_s - 0.1).abs() < 1e-12, "{name}");
        assert_eq!(c.policy.period_s, c.controller.period_s, "{name}");
        c.force_source().unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    let fast = RunConfig::load(cfg("board_sim_fast.toml"), Some("/dev/pts/9")).expect("loads");
    match &fast.link {
        LinkSettings::Rtu(r) => assert_eq!(r.port, "/dev/pts/9", "--port replaces board.port"),
        other => panic!("serial link expected: {other:?}"),
    }
    let can = RunConfig::load_for(cfg("paper_vmc_run.toml"), None, Some("vcan0")).expect("can");
    match &can.link {
        LinkSettings::Can { iface, link } => {
            assert_eq!(iface, "vcan0");
            assert_eq!(link.node, 1);
        }
        other => panic!("CAN link expected: {other:?}"),
    }
    assert_eq!(fast.tick_period(), std::time::Duration::from_millis(25));
    assert_eq!(fast.policy.overload_force_n, 1600.0);
    // [shutdown]: defaults, and the shipped production config's values.
    assert_eq!(
        (fast.shutdown.drain_s, fast.shutdown.air_periods),
        (10.0, 5)
    );
    assert_eq!(fast.shutdown.air_force_n, 0.2 * fast.controller.force_ref_n);
    let prod = RunConfig::load(cfg("paper_vmc_run.toml"), None).expect("loads");
    assert_eq!(prod.shutdown.air_force_n, 160.0);
}

#[test]
fn bad_values_name_file_and_key() {
    let dir = tempfile::tempdir().expect("temp dir");
    let base = std::fs::read_to_string(cfg("board_sim_fast.toml")).expect("base");
    let abs = cfg("").canonicalize().expect("configs/runtime");
    let base = base
        .replace("\"../presets/", &format!("\"{}/../presets/", abs.display()))
        .replace(
            "\"paper_vmc_power.toml\"",
            &format!("\"{}/paper_vmc_power.toml\"", abs.display()),
        );
    for (from, to, key) in [
        (
            "time_scale = 4.0",
            "time_scale = 1000.0",
            "runtime.time_scale",
        ),
        (
            "max_override_pct = 150",
            "max_override_pct = 170",
            "policy.max_override_pct",
        ),
        ("slave = 1", "slave = 0", "board.slave"),
        (
            "link_hold_periods = 5",
            "link_hold_periods = 0",
            "policy.link_hold_periods",
        ),
        (
            "[runtime]",
            "[shutdown]\nair_periods = 0\n[runtime]",
            "shutdown.air_periods",
        ),
        (
            "[runtime]",
            "[shutdown]\ndrain_s = -1.0\n[runtime]",
            "shutdown.drain_s",
        ),
        ("name = ", "bogus_key = 1\nname = ", "bogus_key"),
        (
            "[runtime]",
            "[runtime]\nreconnect_timeout_s = 0.0",
            "runtime.reconnect_timeout_s",
        ),
        (
            "[runtime]",
            "[runtime]\non_device_lost = \"sometimes\"",
            "on_device_lost",
        ),
        (
            "slave = 1",
            "slave = 1\nfallback_mode = \"never\"",
            "board.fallback_mode",
        ),
    ] {
        assert!(base.contains(from), "{from}");
        let p = dir.path().join("run.toml");
        std::fs::write(&p, base.replacen(from, to, 1)).expect("write");
        let e = RunConfig::load(&p, None).expect_err(key).to_string();
        assert!(
            e.contains(&p.display().to_string()) && e.contains(key),
            "{key}: {e}"
        );
    }
}

#[test]
fn fallback_mode_and_device_loss_keys() {
    use acc_pmc::regs::FallbackMode;
    use acc_runtime::config::DeviceLostAction;
    let dir = tempfile::tempdir().expect("temp dir");
    let base = std::fs::read_to_string(cfg("board_sim_fast.toml")).expect("base");
    let abs = cfg("").canonicalize().expect("configs/runtime");
    let base = base
        .replace("\"../presets/", &format!("\"{}/../presets/", abs.display()))
        .replace(
            "\"paper_vmc_power.toml\"",
            &format!("\"{}/paper_vmc_power.toml\"", abs.display()),
        );
    let p = dir.path().join("run.toml");
    std::fs::write(&p, &base).expect("write");
    let d = RunConfig::load(&p, None).expect("defaults");
    assert_eq!(d.fallback_mode, FallbackMode::ClampAndFeedHold);
    assert_eq!(d.runtime.on_device_lost, DeviceLostAction::Exit);
    assert_eq!(d.runtime.reconnect_timeout_s, 10.0);
    let text = base
        .replacen("slave = 1", "slave = 1\nfallback_mode = \"clamp\"", 1)
        .replacen(
            "[runtime]",
            "[runtime]\non_device_lost = \"reconnect\"\nreconnect_timeout_s = 2.5",
            1,
        );
    std::fs::write(&p, text).expect("write");
    let c = RunConfig::load(&p, None).expect("loads");
    assert_eq!(c.fallback_mode, FallbackMode::ClampOnly);
    assert_eq!(c.runtime.on_device_lost, DeviceLostAction::Reconnect);
    assert_eq!(c.runtime.reconnect_timeout_s, 2.5);
    let e = {
        let t = base.replacen("slave = 1", "slave = 1\nfallback_mode = 1", 1);
        std::fs::write(&p, t).expect("write");
        RunConfig::load(&p, None).expect_err("a number").to_string()
    };
    assert!(
        e.contains("board.fallback_mode") && e.contains("clamp_and_feed_hold"),
        "{e}"
    );
}

#[test]
fn watch_keys_resolve_and_bad_ones_name_file_key_value_and_range() {
    let dir = tempfile::tempdir().expect("temp dir");
    let base = std::fs::read_to_string(cfg("board_sim_fast.toml")).expect("base");
    let abs = cfg("").canonicalize().expect("configs/runtime");
    let base = base
        .replace("\"../presets/", &format!("\"{}/../presets/", abs.display()))
        .replace(
            "\"paper_vmc_power.toml\"",
            &format!("\"{}/paper_vmc_power.toml\"", abs.display()),
        );
    let p = dir.path().join("run.toml");
    std::fs::write(&p, &base).expect("write");
    let d = RunConfig::load(&p, None).expect("defaults");
    assert_eq!(d.watch, acc_runtime::watch::WatchLimits::default());
    assert_eq!(d.history, None);
    std::fs::write(
        &p,
        format!("{base}\n[watch]\nhistory = \"hist/tools.sqlite\"\nwear_warn_pct = 20.0\nbreakage_spike_factor = 4.0\n"),
    )
    .expect("write");
    let c = RunConfig::load(&p, None).expect("watch keys");
    assert_eq!(c.watch.wear_warn_pct, 20.0);
    assert_eq!(c.watch.breakage_spike_factor, 4.0);
    assert_eq!(c.history, Some(dir.path().join("hist/tools.sqlite")));
    for (table, key, value, allowed) in [
        (
            "wear_limit_pct = 10.0",
            "watch.wear_limit_pct",
            "10",
            "wear_warn_pct <= x <= 1000",
        ),
        (
            "breakage_drop_pct = 100.0",
            "watch.breakage_drop_pct",
            "100",
            "0 < x < 100",
        ),
        (
            "breakage_history_periods = 40",
            "watch.breakage_history_periods",
            "40",
            "3 ..= 32",
        ),
    ] {
        std::fs::write(&p, format!("{base}\n[watch]\n{table}\n")).expect("write");
        let e = RunConfig::load(&p, None).expect_err(key).to_string();
        assert!(
            e.contains(&p.display().to_string())
                && e.contains(key)
                && e.contains(value)
                && e.contains(allowed),
            "{key}: {e}"
        );
    }
    // An unknown key is named, with a suggestion.
    std::fs::write(&p, format!("{base}\n[watch]\nwear_warn = 20.0\n")).expect("write");
    let e = RunConfig::load(&p, None).expect_err("unknown").to_string();
    assert!(
        e.contains("wear_warn") && e.contains("wear_warn_pct"),
        "{e}"
    );
}
