//! One plant: the twin (`acc-ident`) replays logs only through the simulator's plant
//! (`acc_sim::replay`, the same `Machine` that `acc sim` steps). It has no feed drive,
//! override path or motor dynamics of its own: a change to the plant is made once.

use std::path::{Path, PathBuf};

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
    for e in std::fs::read_dir(dir).expect("readable dir").flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
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
