//! The path as straight pieces, on every program of `tests/nc/`: pieces join up (except
//! where a tool length offset changes what the tool tip is), every chord stays within the
//! chord tolerance of its arc, and the pieces add up to the summary's lengths.

use std::path::Path;

use acc_nc::{interpret, Canon, Setup, ToolTable, Units};

const TOL_MM: f64 = 0.01;

fn programs() -> Vec<(String, acc_nc::Program)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/nc");
    let tbl = std::fs::read_to_string(dir.join("tools.tbl")).expect("tools.tbl");
    let setup = Setup {
        tools: ToolTable::parse_tbl("tools.tbl", &tbl, Units::Inch).expect("table"),
        ..Setup::default()
    };
    let mut out = Vec::new();
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("tests/nc")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "ngc"))
        .collect();
    files.sort();
    for f in files {
        let name = f.display().to_string();
        let text = std::fs::read_to_string(&f).expect("program");
        out.push((
            name.clone(),
            interpret(&name, &text, &setup).expect("accepted"),
        ));
    }
    assert!(out.len() >= 20);
    out
}

#[test]
fn pieces_join_and_add_up() {
    for (name, p) in programs() {
        let tlo_lines: Vec<u32> = p
            .calls
            .iter()
            .filter(|c| matches!(c.call, Canon::ToolLengthOffset { .. }))
            .map(|c| c.line)
            .collect();
        let path = p.path(TOL_MM);
        for w in path.windows(2) {
            let gap = (0..3)
                .map(|a| (w[1].from[a] - w[0].to[a]).abs())
                .fold(0.0, f64::max);
            let tlo_between = tlo_lines.iter().any(|&l| l > w[0].line && l <= w[1].line);
            assert!(
                gap < 1e-9 || tlo_between,
                "{name}: gap {gap} before line {}",
                w[1].line
            );
        }
        let s = p.summary();
        let feed: f64 = path
            .iter()
            .filter(|s| !s.rapid)
            .map(|s| s.length_mm())
            .sum();
        let rapid: f64 = path.iter().filter(|s| s.rapid).map(|s| s.length_mm()).sum();
        assert!((rapid - s.rapid_length_mm).abs() < 1e-9, "{name}");
        // Chords are shorter than their arcs, by at most a fraction ~ tol / r.
        assert!(feed <= s.feed_length_mm + 1e-9, "{name}");
        assert!(
            feed >= s.feed_length_mm * 0.995,
            "{name}: {feed} vs {}",
            s.feed_length_mm
        );
    }
}

#[test]
fn chords_stay_within_the_tolerance_of_their_arc() {
    for (name, p) in programs() {
        for c in &p.calls {
            let Canon::Arc {
                center,
                from,
                plane,
                ..
            } = c.call
            else {
                continue;
            };
            let one = acc_nc::Program {
                file: name.clone(),
                calls: vec![c.clone()],
            };
            // Distance from the centre in the arc's plane (the work offsets are zero here).
            let radius = |p: [f64; 3]| {
                let q = plane.project(p);
                (q[0] - center[0]).hypot(q[1] - center[1])
            };
            let r = radius(from);
            for seg in one.path(TOL_MM) {
                let mid = [0, 1, 2].map(|k| (seg.from[k] + seg.to[k]) / 2.0);
                let sagitta = r - radius(mid);
                assert!(
                    sagitta <= TOL_MM + 1e-6,
                    "{name}:{}: sagitta {sagitta}",
                    c.line
                );
                let ends_on_circle = [seg.from, seg.to]
                    .iter()
                    .all(|&p| (radius(p) - r).abs() < 0.003);
                assert!(ends_on_circle, "{name}:{}", c.line);
            }
        }
    }
}
