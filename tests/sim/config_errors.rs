//! Bad scenario files give a clear error naming the file and the key.

use std::path::Path;

use acc_sim::run::configs_dir;
use acc_sim::Scenario;

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

fn scenario_text(workpiece: &str, extra: &str) -> String {
    let c = configs_dir();
    let c = c.display();
    format!(
        "name = \"t\"\nmachine = \"{c}/machines/paper_vmc.toml\"\n\
         tool = \"{c}/machines/tools/hss_endmill_16_4f.toml\"\nworkpiece = \"{workpiece}\"\n\
         controller = \"{c}/presets/case3.toml\"\nseed = 1\nprogrammed_feed_mm_min = 200.0\n{extra}"
    )
}

fn err(path: &Path) -> String {
    Scenario::load(path).expect_err("must fail").to_string()
}

#[test]
fn unknown_key_names_file_and_key() {
    let dir = tempfile::tempdir().expect("tmp");
    let wp = configs_dir().join("workpieces/steps_2_3_4.toml");
    let p = write(
        dir.path(),
        "s.toml",
        &scenario_text(&wp.display().to_string(), "sede = 3\n"),
    );
    let e = err(&p);
    assert!(e.contains("s.toml") && e.contains("sede"), "{e}");
    // Unknown key inside a table.
    let p = write(
        dir.path(),
        "m.toml",
        &scenario_text(
            &wp.display().to_string(),
            "[measurement]\nkind = \"dynamometer\"\nnoise = 3\n",
        ),
    );
    let e = err(&p);
    assert!(e.contains("m.toml") && e.contains("noise"), "{e}");
}

#[test]
fn negative_depth_names_the_workpiece_file_key_and_range() {
    let dir = tempfile::tempdir().expect("tmp");
    let wp = write(
        dir.path(),
        "w.toml",
        "name = \"w\"\naxial_depth_mm = 16.0\n[[segment]]\nkind = \"air\"\nlength_mm = 10.0\n\
         [[segment]]\nkind = \"cut\"\nlength_mm = 10.0\ndepth_mm = -2.0\n",
    );
    let p = write(dir.path(), "s.toml", &scenario_text("w.toml", ""));
    let e = err(&p);
    assert!(
        e.contains("w.toml") && e.contains("segment[1].depth_mm") && e.contains("-2"),
        "{e}"
    );
    assert!(e.contains("allowed"), "{e}");
    let _ = wp;
}

#[test]
fn missing_file_names_the_file() {
    let dir = tempfile::tempdir().expect("tmp");
    let p = write(
        dir.path(),
        "s.toml",
        &scenario_text("no_such_workpiece.toml", ""),
    );
    let e = err(&p);
    assert!(
        e.contains("no_such_workpiece.toml") && e.contains("cannot read"),
        "{e}"
    );
    // ... and the scenario file and key that named it.
    assert!(e.contains("s.toml") && e.contains("`workpiece`"), "{e}");
    let e = err(&dir.path().join("absent.toml"));
    assert!(e.contains("absent.toml"), "{e}");
}

#[test]
fn out_of_range_values_name_key_and_range() {
    let dir = tempfile::tempdir().expect("tmp");
    let wp = configs_dir().join("workpieces/steps_2_3_4.toml");
    let p = write(
        dir.path(),
        "s.toml",
        &scenario_text(
            &wp.display().to_string(),
            "[measurement]\nkind = \"dynamometer\"\nwindow_s = 0.5\n",
        ),
    );
    let e = err(&p);
    assert!(
        e.contains("measurement.window_s") && e.contains("0.1"),
        "{e}"
    );
    let p = write(
        dir.path(),
        "k.toml",
        &scenario_text(
            &wp.display().to_string(),
            "[measurement]\nkind = \"laser\"\n",
        ),
    );
    let e = err(&p);
    assert!(e.contains("laser") && e.contains("dynamometer"), "{e}");
}

#[test]
fn depth_beyond_the_tool_diameter_names_the_key_as_written() {
    let dir = tempfile::tempdir().expect("tmp");
    let s = write(dir.path(), "s.toml", &scenario_text("w.toml", ""));
    for (segment, key) in [
        (
            "kind = \"cut\"\nlength_mm = 10.0\ndepth_mm = 20.0",
            "segment[1].depth_mm",
        ),
        (
            "kind = \"ramp\"\nlength_mm = 10.0\nfrom_mm = 2.0\nto_mm = 17.0",
            "segment[1].to_mm",
        ),
    ] {
        write(
            dir.path(),
            "w.toml",
            &format!(
                "name = \"w\"\naxial_depth_mm = 16.0\n[[segment]]\nkind = \"air\"\n\
                 length_mm = 10.0\n[[segment]]\n{segment}\n"
            ),
        );
        let e = err(&s);
        assert!(
            e.contains("w.toml") && e.contains(key) && e.contains("tool diameter"),
            "{e}"
        );
    }
}

#[test]
fn nc_context_keys_are_range_checked_and_reach_the_board() {
    use acc_pmc::Board;
    let dir = tempfile::tempdir().expect("tmp");
    let wp = configs_dir().join("workpieces/steps_2_3_4.toml");
    let wp = wp.display().to_string();
    for (extra, key, range) in [
        ("[nc]\ntool_number = -1\n", "nc.tool_number", "0 ..= 65535"),
        (
            "[nc]\nprogram_number = 70000\n",
            "nc.program_number",
            "0 ..= 65535",
        ),
        ("[nc]\nblock_step = 0\n", "nc.block_step", "1 ..= 1000"),
    ] {
        let p = write(dir.path(), "nc.toml", &scenario_text(&wp, extra));
        let e = err(&p);
        assert!(
            e.contains("nc.toml") && e.contains(key) && e.contains(range),
            "{extra}: {e}"
        );
    }
    let p = write(
        dir.path(),
        "nc.toml",
        &scenario_text(&wp, "[nc]\ntool = 3\n"),
    );
    let e = err(&p);
    assert!(e.contains("nc.toml") && e.contains("tool"), "{e}");
    // Valid keys reach the simulated board's registers; defaults fill the rest.
    let p = write(
        dir.path(),
        "ok.toml",
        &scenario_text(&wp, "[nc]\ntool_number = 12\nblock_step = 5\n"),
    );
    let sc = Scenario::load(&p).expect("valid");
    let s = sc.build_board().read_status().expect("status");
    assert_eq!(
        (s.tool_number, s.program_number, s.block_number),
        (12, 1000, 5)
    );
}
