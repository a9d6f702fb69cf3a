//! A short soak, end to end: `acc soak` on the fault matrix's hostile line (1 % garbage
//! throughout, two delay episodes) with a random board fault every few seconds for 200 s of
//! machine time: no lost rows, no dead thread, the invariant holds.

use crate::e2e_support::{acc_output, one_at_a_time};

#[test]
fn a_short_soak_with_random_faults_loses_no_rows_and_keeps_every_thread() {
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("soak");
    // The hostile line (the default) with a delay episode every 60 s: two in 200 s.
    let (ok, stdout, stderr) = acc_output(&[
        "soak",
        "--machine-s",
        "200",
        "--seed",
        "3",
        "--delay-every-s",
        "60",
        "--out",
        &out.to_string_lossy(),
    ]);
    println!("{stdout}\n{stderr}");
    assert!(ok, "acc soak failed:\n{stdout}\n{stderr}");
    let json = std::fs::read_to_string(out.join("soak.json")).expect("json");
    let r: serde_json::Value = serde_json::from_str(&json).expect("report");
    assert!(r["faults_fired"].as_u64().unwrap_or(0) >= 40, "{r}");
    assert_eq!(r["run_missing"].as_u64(), Some(0), "{r}");
    assert_eq!(r["raised_in_fault"].as_u64(), Some(0), "{r}");
    assert!(r["machine_s"].as_f64().unwrap_or(0.0) > 190.0, "{r}");
    let line = &r["line"];
    assert!(line["corrupted"].as_u64().unwrap_or(0) > 0, "{r}");
    assert_eq!(line["episodes"], 2, "{r}");
    assert_eq!(line["episodes_planned"], 2, "{r}");
    assert!(line["delayed_reads"].as_u64().unwrap_or(0) > 0, "{r}");
}
