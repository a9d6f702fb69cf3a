//! The twin on LinuxCNC's motion (docs/twin-linuxcnc.md): `acc linuxcnc`
//! runs `tests/nc/linuxcnc_accel.ngc` with X and Y accelerating at 20 mm/s² (`--ini`), a
//! value the model (`configs/models/linuxcnc_paper_vmc.toml`: the template's 500 mm/s²) is
//! not told. `acc discrepancy --program` on its run log must fit `feed_accel_limit` and
//! shrink the sealed part's force residual by a third or more. At 20 mm/s² acc's own
//! loop-delay watch releases in the second slot (`delay`) and the program is aborted; the
//! log up to there is analysed. The name is not asserted: the fit stays ambiguous with
//! `measurement_delay`, and its interval (about 1000/a = 78–93 s²/m) misses the INI's 48,
//! since LinuxCNC ramps an override change at about 8 mm/s², a start at 20.
//!
//! Needs LinuxCNC: absent, the test prints `SKIP: …` and passes, unless `CI` is set, then
//! it fails. One LinuxCNC runs per host: the run holds the LinuxCNC tests' file lock.

use std::fs::File;
use std::path::Path;
use std::process::Command;

const PROGRAM: &str = "../../tests/nc/linuxcnc_accel.ngc";
const STOCK_BOX: &str = "0,-20,-10,40,20,0";
const MODEL: &str = "../../configs/models/linuxcnc_paper_vmc.toml";
/// The hidden X and Y acceleration, mm/s², and the model's own.
const HIDDEN_MM_S2: f64 = 20.0;
const MODEL_MM_S2: f64 = 500.0;

/// `acc ARGS`: its stdout; the test fails with stdout and stderr if it fails (or, with
/// `may_abort`, if it fails for another reason than a program that did not complete).
fn acc(args: &[&str], may_abort: bool) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_acc"))
        .args(args)
        .output()
        .expect("acc runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let aborted = String::from_utf8_lossy(&out.stderr).contains("the program did not complete");
    assert!(
        out.status.success() || (may_abort && aborted),
        "acc {args:?}: {}\nstdout:\n{stdout}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// The numbers of `acc discrepancy`'s line `param NAME = V [LO, HI]`.
fn param(out: &str, name: &str) -> Option<(f64, f64, f64)> {
    let line = out
        .lines()
        .find_map(|l| l.strip_prefix(&format!("param {name} = ")))?;
    let (v, rest) = line.split_once(" [")?;
    let (lo, hi) = rest.trim_end_matches(']').split_once(", ")?;
    Some((v.parse().ok()?, lo.parse().ok()?, hi.parse().ok()?))
}

/// The sealed part's RMS, nominal and updated (`sealed rms A -> B N`).
fn sealed_rms(out: &str) -> (f64, f64) {
    let line = out
        .lines()
        .find_map(|l| l.strip_prefix("sealed rms "))
        .expect("the sealed line");
    let (a, b) = line.split_once(" -> ").expect("a -> b");
    let b = b.split_whitespace().next().expect("b");
    (a.parse().expect("a"), b.parse().expect("b"))
}

// Not in the default suite: on a loaded 2-core host the run is often cut short (the
// watchdog trips at start-up, or acc's delay watch releases before the second slot), and
// the sealed part then holds no cut; in 1 of 4 runs the fit also took `feed_drive_lag`.
// Run it on a quiet host: `cargo test -p acc-cli --test cli linuxcnc_twin -- --ignored`.
#[test]
#[ignore = "an evaluation run on LinuxCNC: needs a quiet host (see the comment above)"]
fn the_twin_fits_linuxcnc_s_acceleration_limit_and_the_gap_shrinks() {
    if let Some(reason) = super::linuxcnc::missing_linuxcnc() {
        if std::env::var_os("CI").is_some() {
            panic!("LinuxCNC is required under CI: {reason} (run `bash .ci/deps`)");
        }
        eprintln!("SKIP: {reason} (apt-get install linuxcnc-uspace); LinuxCNC twin test not run");
        return;
    }
    let lock = File::create(std::env::temp_dir().join("acc-linuxcnc-test.lock")).expect("lock");
    lock.lock().expect("the LinuxCNC test lock");
    let tmp = tempfile::tempdir().expect("temp dir");
    let run = tmp.path().join("run");
    let accel = format!("{HIDDEN_MM_S2}");
    let (x, y) = (
        format!("--ini=AXIS_X.MAX_ACCELERATION={accel}"),
        format!("--ini=AXIS_Y.MAX_ACCELERATION={accel}"),
    );
    let run_s = run.display().to_string();
    let stock = format!("--stock-box={STOCK_BOX}");
    acc(
        &[
            "linuxcnc",
            PROGRAM,
            &stock,
            "--out",
            &run_s,
            "--timeout-s",
            "60",
            "--watchdog-s",
            "0.5",
            &x,
            &y,
        ],
        true,
    );
    let ini = std::fs::read_to_string(run.join("acc.ini")).expect("acc.ini");
    assert_eq!(
        ini.matches(&format!("MAX_ACCELERATION = {accel}")).count(),
        4,
        "X and Y, axis and joint: {ini}"
    );
    let measured = run.join("run.csv").display().to_string();
    let out_dir = tmp.path().join("disc").display().to_string();
    let out = acc(
        &[
            "discrepancy",
            "--model",
            MODEL,
            "--measured",
            &measured,
            "--program",
            PROGRAM,
            &stock,
            "--out",
            &out_dir,
        ],
        false,
    );
    eprintln!("{out}");
    let truth = 1000.0 / HIDDEN_MM_S2 - 1000.0 / MODEL_MM_S2;
    let (v, lo, hi) =
        param(&out, "feed_accel_limit.inverse_accel_s2_per_m").expect("the fitted limit");
    eprintln!("1000/a = {v:.1} [{lo:.1}, {hi:.1}] s²/m, the INI's {truth:.1}");
    assert!(
        lo > 0.0,
        "the limit's interval excludes its null: [{lo}, {hi}]"
    );
    let (nominal, updated) = sealed_rms(&out);
    assert!(
        updated < 0.67 * nominal,
        "sealed force RMS {nominal:.1} -> {updated:.1} N"
    );
    assert!(Path::new(&out_dir).join("where.md").is_file());
}
