//! One clock, one plant: the source tree is checked for the two things that must stay in one
//! place.
//!
//! - **One clock.** No source file outside the clock module reads the wall clock or sleeps,
//!   so the loop, the plant, the board emulators, `acc sim` and `acc board-sim` run on
//!   whatever clock they are given (`acc_core::clock`: the system clock, a scaled one, or the
//!   stepped clock). The exceptions are listed with their reason.
//! - **One plant.** The twin (`acc-ident`) replays logs only through the simulator's plant
//!   (`acc_plant::replay`, the same `Machine` that `acc sim` steps): it has no feed drive,
//!   override path or motor dynamics of its own.

use std::path::{Path, PathBuf};

/// Files (or path prefixes, relative to the workspace root) that may read the wall clock.
const ALLOWED: &[(&str, &str)] = &[
    ("crates/acc-core/src/clock.rs", "the clock implementations"),
    (
        "crates/acc-telemetry/src/",
        "telemetry servers: client timeouts and keep-alives on the wall clock",
    ),
    (
        "crates/acc-cli/src/telemetry.rs",
        "keeps the live view up after a run, in wall time",
    ),
    (
        "crates/acc-runtime/src/tap.rs",
        "the telemetry tap's test that publishing never blocks",
    ),
    (
        "crates/acc-harness/src/",
        "the fault matrix and soak harness: wall-clock timeouts on the processes it drives",
    ),
    (
        "crates/xtask/src/",
        "the development tool: how long a package build took",
    ),
];

/// What reads the wall clock or blocks on it without a `Clock`.
const FORBIDDEN: &[&str] = &["Instant::now", "thread::sleep", "use std::thread::{sleep"];

/// What integrating a feed drive, an override delay line or a lag looks like.
const PLANT_DYNAMICS: &[&str] = &[
    "FirstOrderLag",
    "step_from(",
    "fn feed_path",
    "fn override_path",
    "MotorSim",
    "Machine::new(",
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn no_wall_clock_outside_the_clock_module() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&root.join("sim/src"), &mut files);
    for c in std::fs::read_dir(root.join("crates"))
        .expect("crates/")
        .flatten()
    {
        rust_files(&c.path().join("src"), &mut files);
    }
    assert!(files.len() > 50, "found only {} source files", files.len());
    let mut hits = Vec::new();
    for f in &files {
        let rel = f
            .strip_prefix(root)
            .expect("under the root")
            .to_string_lossy()
            .replace('\\', "/");
        if ALLOWED.iter().any(|(prefix, _)| rel.starts_with(prefix)) {
            continue;
        }
        let text = std::fs::read_to_string(f).expect("readable");
        for (i, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            if FORBIDDEN.iter().any(|p| code.contains(p)) {
                hits.push(format!("{rel}:{}: {}", i + 1, line.trim()));
            }
        }
    }
    assert!(
        hits.is_empty(),
        "the wall clock read outside acc_core::clock (take time from an injected Clock):\n{}",
        hits.join("\n")
    );
}

#[test]
fn the_twin_has_no_plant_dynamics_of_its_own() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&root.join("crates/acc-ident/src"), &mut files);
    assert!(files.len() > 10, "found only {} files", files.len());
    let mut hits = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).expect("readable");
        for (i, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            if PLANT_DYNAMICS.iter().any(|p| code.contains(p)) {
                hits.push(format!(
                    "{}:{}: {}",
                    f.strip_prefix(root).unwrap_or(f).display(),
                    i + 1,
                    line.trim()
                ));
            }
        }
    }
    assert!(
        hits.is_empty(),
        "plant dynamics in acc-ident (replay through acc_sim::replay instead):\n{}",
        hits.join("\n")
    );
}
