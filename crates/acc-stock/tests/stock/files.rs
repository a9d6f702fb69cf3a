//! `stock.toml` and height-map files: what loads, and errors that name the file, the key
//! or line, and the allowed range.

use std::path::Path;

use acc_stock::{load_stock, BoxSpec, StockFile};

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

#[test]
fn box_stock_loads_with_the_default_cell() {
    let dir = tempfile::tempdir().expect("tmp");
    let p = write(
        dir.path(),
        "stock.toml",
        "[box]\nmin_mm = [0.0, 0.0, -30.0]\nmax_mm = [200.0, 100.0, 0.0]\n",
    );
    let m = load_stock(&p).expect("loads");
    assert_eq!(m.cell_mm(), 0.25);
    assert_eq!(m.size(), (800, 400));
    assert_eq!((m.bottom_mm(), m.max_height_mm()), (-30.0, 0.0));
    assert!((m.volume_mm3() - 200.0 * 100.0 * 30.0).abs() < 1e-6);
}

#[test]
fn stock_toml_errors_name_file_key_and_range() {
    let dir = tempfile::tempdir().expect("tmp");
    let boxed = "[box]\nmin_mm = [0.0, 0.0, -30.0]\nmax_mm = [20.0, 10.0, 0.0]\n";
    let cases = [
        (
            format!("cell_mm = 50.0\n{boxed}"),
            "key `cell_mm` = 50 is out of range: allowed 0.01 ..= 10",
        ),
        (format!("cell = 0.5\n{boxed}"), "key `cell`: unknown key (line 1, column 1)"),
        (
            "[box]\nmin_mm = [0.0, 0.0, 0.0]\nmax_mm = [20.0, 10.0, -5.0]\n".to_string(),
            "key `box.max_mm[2]` = -5 is out of range: allowed > box.min_mm[2] = 0",
        ),
        ("cell_mm = 0.5\n".to_string(), "key `box`: give exactly one"),
        (
            format!("{boxed}[height_map]\nfile = \"m.csv\"\ncorner_mm = [0.0, 0.0]\npitch_mm = 1.0\nbottom_mm = -5.0\n"),
            "give exactly one of [box] and [height_map]",
        ),
        (
            "[height_map]\nfile = \"m.csv\"\ncorner_mm = [0.0, 0.0]\npitch_mm = 0.0\nbottom_mm = -5.0\n".to_string(),
            "key `height_map.pitch_mm` = 0 is out of range: allowed 0.01 ..= 100",
        ),
    ];
    for (text, want) in cases {
        let p = write(dir.path(), "stock.toml", &text);
        let e = load_stock(&p).expect_err(want).to_string();
        assert!(e.contains(want), "{e}\nwanted: {want}");
        assert!(e.contains("stock.toml"), "{e}");
    }
}

#[test]
fn height_map_loads_resampled_and_relative_to_the_stock_file() {
    let dir = tempfile::tempdir().expect("tmp");
    std::fs::create_dir(dir.path().join("maps")).expect("mkdir");
    // 4 × 2 cells of 1 mm: a 2 mm step down at x ≥ 2.
    write(
        &dir.path().join("maps"),
        "step.csv",
        "# a step\n0, 0, -2, -2\n0, 0, -2, -2\n",
    );
    let p = write(
        dir.path(),
        "stock.toml",
        "cell_mm = 0.5\n[height_map]\nfile = \"maps/step.csv\"\ncorner_mm = [10.0, 20.0]\npitch_mm = 1.0\nbottom_mm = -10.0\n",
    );
    let m = load_stock(&p).expect("loads");
    assert_eq!(m.size(), (8, 4));
    assert_eq!(m.corner_mm(), [10.0, 20.0]);
    assert_eq!(m.height_at(11.9, 21.0), Some(0.0));
    assert_eq!(m.height_at(12.1, 21.0), Some(-2.0));
    assert!((m.volume_mm3() - (2.0 * 2.0 * 10.0 + 2.0 * 2.0 * 8.0)).abs() < 1e-9);
}

#[test]
fn height_map_errors_name_the_line() {
    let dir = tempfile::tempdir().expect("tmp");
    let toml = "[height_map]\nfile = \"m.csv\"\ncorner_mm = [0.0, 0.0]\npitch_mm = 1.0\nbottom_mm = -10.0\n";
    let p = write(dir.path(), "stock.toml", toml);
    let map = dir.path().join("m.csv");
    let cases = [
        (
            "0, 0\n# note\n0, 0.5.1\n",
            "m.csv:3:2: `0.5.1` is not a height in mm: allowed -10 ..= 990",
        ),
        (
            "0, 0\n0, -12\n",
            "m.csv:2:2: height -12 is out of range: allowed -10 ..= 990",
        ),
        (
            "0, 0\n\n0, 0, 0\n",
            "m.csv:3: row has 3 values, the first row has 2",
        ),
        ("0, inf\n", "m.csv:1:2: height inf is out of range"),
    ];
    for (text, want) in cases {
        std::fs::write(&map, text).expect("write");
        let e = load_stock(&p).expect_err(want).to_string();
        assert!(e.contains(want), "{e}\nwanted: {want}");
    }
    // A missing map names the stock file's key and the path it resolved to.
    std::fs::remove_file(&map).expect("rm");
    let e = load_stock(&p).expect_err("missing").to_string();
    assert!(
        e.contains("stock.toml") && e.contains("height_map.file") && e.contains("m.csv"),
        "{e}"
    );
}

#[test]
fn box_shortcut_parses_six_numbers() {
    let b: BoxSpec = "0,0,-30, 200,100,0".parse().expect("six");
    assert_eq!(
        (b.min_mm, b.max_mm),
        ([0.0, 0.0, -30.0], [200.0, 100.0, 0.0])
    );
    assert!("0,0,1".parse::<BoxSpec>().is_err());
    assert!("0,0,a,1,1,1".parse::<BoxSpec>().is_err());
    let f = StockFile::parse(
        Path::new("s.toml"),
        "[box]\nmin_mm = [0.0, 0.0, 0.0]\nmax_mm = [1.0, 1.0, 1.0]\n",
    )
    .expect("parses");
    assert_eq!(f.cell_mm, 0.25);
}
