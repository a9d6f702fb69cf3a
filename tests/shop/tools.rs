//! The shop tool table in the production loop: two tools switching mid-program on the
//! emulated v2 board, and tool-table errors through a scenario.

use acc_sim::{LawKind, Scenario};

fn configs() -> std::path::PathBuf {
    acc_sim::run::configs_dir()
}

#[test]
fn two_tools_switch_mid_program_without_a_bump() {
    let sc = Scenario::load(configs().join("scenarios/two_tools.toml")).expect("loads");
    let (res, _) = sc.run_law(LawKind::Ours).expect("runs");
    let rows = &res.rows;
    let sw = rows
        .iter()
        .position(|r| r.tool == Some(2))
        .expect("the board reports tool 2");
    assert!(rows[..sw].iter().all(|r| r.tool == Some(1)));
    assert!(rows[sw].flags.contains("tool_change"), "{}", rows[sw].flags);
    // The override never rises at the switch (nor in the next period).
    let before = rows[sw - 1].override_cmd_pct.expect("cmd");
    for r in &rows[sw..sw + 2] {
        assert!(
            r.override_cmd_pct.expect("cmd") <= before,
            "rose at the switch"
        );
    }
    // Each tool's Fr is the loop's reference, and the force settles at it.
    let mean = |rs: &[acc_runtime::RunRecord]| {
        let f: Vec<f64> = rs.iter().filter_map(|r| r.force_n).collect();
        f.iter().sum::<f64>() / f.len() as f64
    };
    assert_eq!(rows[sw - 1].force_ref_n, Some(800.0));
    assert_eq!(rows[sw + 1].force_ref_n, Some(500.0));
    let t1 = mean(&rows[sw - 60..sw]);
    let t2 = mean(&rows[sw + 60..sw + 120]);
    assert!((t1 - 800.0).abs() < 40.0, "tool 1 mean {t1}");
    assert!((t2 - 500.0).abs() < 40.0, "tool 2 mean {t2}");
}

#[test]
fn a_bad_tool_table_names_file_key_value_and_range() {
    let dir = std::env::temp_dir().join(format!("acc_shop_tools_{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("ok");
    let table = dir.join("tools.toml");
    let scenario = dir.join("s.toml");
    let text = std::fs::read_to_string(configs().join("scenarios/two_tools.toml")).expect("ok");
    let c = configs();
    let text = text
        .replace("../machines", &format!("{}/machines", c.display()))
        .replace("../workpieces", &format!("{}/workpieces", c.display()))
        .replace("../presets", &format!("{}/presets", c.display()))
        .replace("../tooltable.toml", "tools.toml");
    std::fs::write(&scenario, text).expect("ok");
    for (bad, key, value, range) in [
        (
            "[default]\nfr_n = 800.0\n[tool.2]\nfr_n = 0.0\n",
            "tool.2.fr_n",
            "0",
            "1 ..= 100000",
        ),
        (
            "[default]\nfr_n = 800.0\nmin_override_pct = 160\n",
            "default.min_override_pct",
            "160",
            "0 ..= 150",
        ),
        (
            "[default]\nfr_n = 800.0\n[entry]\nsettle_s = 99.0\n",
            "entry.settle_s",
            "99",
            "0.2 ..= 30",
        ),
        (
            "[default]\nfr_n = 800.0\n[tool.7]\nwear_limit_pct = 10.0\nwear_warn_pct = 20.0\n",
            "tool.7.wear_limit_pct",
            "10",
            "20 ..= 1000",
        ),
    ] {
        std::fs::write(&table, bad).expect("ok");
        let e = Scenario::load(&scenario).expect_err("fails").to_string();
        assert!(e.contains("tools.toml"), "{e}");
        assert!(
            e.contains(key) && e.contains(value) && e.contains(range),
            "{e}"
        );
    }
    std::fs::write(
        &table,
        "[default]\nfr_n = 800.0\n[tool.2]\nmax_overide_pct = 100\n",
    )
    .expect("ok");
    let e = Scenario::load(&scenario).expect_err("fails").to_string();
    assert!(e.contains("did you mean `tool.2.max_override_pct`"), "{e}");
    std::fs::remove_file(&table).expect("ok");
    let e = Scenario::load(&scenario).expect_err("fails").to_string();
    assert!(e.contains("tools.file"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
