//! `acc nc`: the binary on a program of ours (table and summary) and on a bad program
//! (exit code 2, the error names file:line:column and the word).

use std::path::PathBuf;
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn acc_nc_prints_a_table_and_a_summary() {
    let out = Command::new(env!("CARGO_BIN_EXE_acc"))
        .arg("nc")
        .arg(root().join("tests/nc/two_tools.ngc"))
        .arg("--tools")
        .arg(root().join("tests/nc/tools.tbl"))
        .arg("--table-units")
        .arg("in")
        .output()
        .expect("run acc");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout
            .lines()
            .next()
            .is_some_and(|l| l.contains("F mm/min")),
        "{stdout}"
    );
    assert!(stdout.contains("arc-cw"), "{stdout}");
    assert!(stdout.contains("tool changes   3"), "{stdout}");
    assert!(stdout.contains("motions        14"), "{stdout}");
}

#[test]
fn acc_nc_names_the_place_of_an_error() {
    let dir = tempfile::tempdir().expect("tmp");
    let file = dir.path().join("bad.ngc");
    std::fs::write(&file, "G21\nG0 X0\nG93 G1 X1 F100\nM2\n").expect("write");
    let out = Command::new(env!("CARGO_BIN_EXE_acc"))
        .arg("nc")
        .arg(&file)
        .output()
        .expect("run acc");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("bad.ngc:3:1: `G93`"), "{stderr}");
    assert!(stderr.contains("only G94"), "{stderr}");
    assert!(out.stdout.is_empty());
}
