//! Bad input: each error names file:line:column, the word, and what is allowed.

use acc_nc::{interpret, ErrorKind, Setup, ToolEntry, ToolTable};

fn err(text: &str) -> acc_nc::NcError {
    interpret("part.ngc", text, &Setup::default()).expect_err("must be refused")
}

#[test]
fn each_bad_input_names_file_line_column_and_word() {
    let cases: &[(&str, &str, (u32, u32), &str)] = &[
        ("G21\nG0 X1 E5\n", "E5", (2, 7), "supported words"),
        ("G21\nG0 G1 X1 F100\n", "G1", (2, 4), "one modal group"),
        (
            "G21 G0 X0 Y0\nG2 X10.01 Y0 I5 J0 F100\n",
            "I5",
            (2, 14),
            "allowed 0.005 mm",
        ),
        ("G21\nG0 X1\nG1 X2\n", "G1", (3, 1), "give F"),
        (
            "G21 G18 G0 X0\nG2 X2 I1 J1 F100\n",
            "J1",
            (2, 10),
            "G18 takes K and I",
        ),
        ("G21\nG19 G41.1 D5\n", "G41.1", (2, 5), "YZ plane (G19)"),
        ("G21\nG1 X1 D2 F100\n", "D2", (2, 7), "G41, G42"),
        ("G21\nG41 D1.5\n", "D1.5", (2, 5), "whole tool number"),
        ("G21\nG41 D7\n", "D7", (2, 5), "not in the tool table"),
        ("G21\nG42.1\n", "G42.1", (2, 1), "D (the tool diameter)"),
        ("G21\nG41.1 D2\nG18\n", "G18", (3, 1), "cancel it with G40"),
        ("G21\nG41.1 D2\nG42.1 D2\n", "G42.1", (3, 1), "already on"),
        (
            "G21\nG41.1 D2\nG1 X5 F100\nG81 X1 Z-1 R1\n",
            "G81",
            (4, 1),
            "canned cycles while it is on",
        ),
        // The entry move must be longer than the tool radius (5 mm).
        (
            "G21 G0 X0 Y0\nG41.1 D10\nG1 X4 F100\n",
            "G1",
            (3, 1),
            "not longer than the tool radius 5.0000 mm",
        ),
        // The tool (radius 5 mm, left of the path) inside a G3 arc of radius 4 mm.
        (
            "G21 G0 X0 Y0\nG41.1 D10\nG1 X20 F100\nG3 X24 Y4 J4\n",
            "G3",
            (4, 1),
            "tool radius 5.0000 mm is not less than the radius 4.0000 mm",
        ),
        // An arc just after G40.
        (
            "G21 G0 X0 Y0\nG41.1 D2\nG1 X10 F100\nG40\nG2 X12 Y2 J2\n",
            "G2",
            (5, 1),
            "must be straight",
        ),
        (
            "G21\nG84 X1 Z-1 R1 F100\n",
            "G84",
            (2, 1),
            "G81 G82 G83 are supported",
        ),
        (
            "G21\nG85 X1 Z-1 R1 F100\n",
            "G85",
            (2, 1),
            "G81 G82 G83 are supported",
        ),
        (
            "G21 G0 Z5\nG83 X1 Z-1 R1 F100\n",
            "G83",
            (2, 1),
            "Q (peck depth)",
        ),
        (
            "G21 G0 Z5\nG81 X1 Z2 R1 F100\n",
            "Z2",
            (2, 8),
            "at or below R",
        ),
        ("G21\nT7 M6\n", "T7", (2, 1), "not in the tool table"),
        ("G21\nG0 A10\n", "A10", (2, 4), "only X Y Z"),
        ("G21\no100 if [1]\n", "O100IF[1]", (2, 1), "control flow"),
        ("G21\no7 sub\nG0 X1\n", "O7SUB", (2, 1), "o7 endsub"),
        ("G21\nG28\n", "G28", (2, 1), "G28"),
        ("G21\nG1 X1 F-5\n", "F-5", (2, 7), "F >= 0"),
        (
            "G21 G0 X0 Y0\nG2 X0 Y0 R5 F100\n",
            "R5",
            (2, 10),
            "full circles take I/J",
        ),
    ];
    for (text, word, (line, column), allowed) in cases {
        let e = err(text);
        let msg = e.to_string();
        assert_eq!(&e.word, word, "{msg}");
        assert_eq!((e.span.line, e.span.column), (*line, *column), "{msg}");
        assert!(
            msg.starts_with(&format!("part.ngc:{line}:{column}: `{word}`")),
            "{msg}"
        );
        assert!(msg.contains(allowed), "{msg} lacks {allowed:?}");
    }
}

#[test]
fn g43_uses_the_loaded_tool_or_h_and_moves_the_program_frame() {
    let mut tools = ToolTable::default();
    for (tool, length_mm) in [(1, 50.0), (2, 80.0)] {
        tools.insert(ToolEntry {
            tool,
            pocket: tool,
            length_mm,
            diameter_mm: 10.0,
            comment: String::new(),
        });
    }
    let setup = Setup {
        tools,
        ..Setup::default()
    };
    let p = interpret(
        "t.ngc",
        "G21\nT1 M6\nG43\nG0 X1\nG43 H2\nG0 X2\nG49\nM2\n",
        &setup,
    )
    .expect("ok");
    let z: Vec<f64> = p
        .calls
        .iter()
        .filter_map(|c| c.call.end())
        .map(|e| e[2])
        .collect();
    // The machine stays at Z 0: the program Z moves by the offset change.
    assert_eq!(z, vec![-50.0, -80.0]);
    let e = interpret("t.ngc", "G21\nG43 H3\n", &setup).expect_err("H3 missing");
    assert_eq!(e.kind, ErrorKind::ToolNotInTable { tool: 3 });
}

#[test]
fn inch_feed_and_lengths_are_converted_to_mm() {
    let p = interpret("i.ngc", "G20 G0 X1\nG1 Y1 F10\n", &Setup::default()).expect("ok");
    let feed = p.calls.iter().find_map(|c| match c.call {
        acc_nc::Canon::Feed {
            to, feed_mm_min, ..
        } => Some((to, feed_mm_min)),
        _ => None,
    });
    assert_eq!(feed, Some(([25.4, 25.4, 0.0], 254.0)));
}

#[test]
fn block_numbers_are_the_n_word_else_the_line() {
    let p = interpret("n.ngc", "G21\nN50 G0 X1\nG0 X2\n", &Setup::default()).expect("ok");
    let b: Vec<u32> = p
        .calls
        .iter()
        .filter(|c| c.call.end().is_some())
        .map(|c| c.block_number())
        .collect();
    assert_eq!(b, vec![50, 3]);
}
