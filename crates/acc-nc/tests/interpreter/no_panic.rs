//! Random bytes and random word soup never panic the interpreter: every input gives a
//! program or an error.

use acc_nc::{interpret, Setup};
use proptest::prelude::*;

const SOUP: &[&str] = &[
    "G0",
    "G1",
    "G2",
    "G3",
    "G4",
    "G17",
    "G18",
    "G19",
    "G20",
    "G21",
    "G40",
    "G41",
    "G42",
    "G41.1",
    "G42.1",
    "G43",
    "G49",
    "G54",
    "G59",
    "G80",
    "G81",
    "G90",
    "G91",
    "G90.1",
    "G91.1",
    "G94",
    "M0",
    "M2",
    "M3",
    "M5",
    "M6",
    "M30",
    "X",
    "Y",
    "Z",
    "I",
    "J",
    "K",
    "R",
    "F",
    "S",
    "T",
    "H",
    "P",
    "Q",
    "N10",
    "O1",
    "o1 sub",
    "#1=",
    "#<a>=",
    "#1",
    "#<a>",
    "[",
    "]",
    "+",
    "-",
    "*",
    "/",
    "**",
    "MOD",
    "SIN[",
    "ATAN[1]/[",
    "SQRT[",
    "EXISTS[#<a>]",
    "1",
    "0",
    "-1",
    "2.5",
    ".5",
    "1e9",
    "1000000",
    " ",
    "\n",
    "(",
    ")",
    ";",
    "%",
    "\t",
    "/",
    "=",
    "E",
    "A1",
    "D1",
    "D",
    "D0.5",
    "L2",
];

fn soup() -> impl Strategy<Value = String> {
    proptest::collection::vec(proptest::sample::select(SOUP), 0..80).prop_map(|v| v.concat())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = interpret("fuzz.ngc", &text, &Setup::default());
    }

    #[test]
    fn word_soup_never_panics(text in soup()) {
        if let Ok(p) = interpret("soup.ngc", &text, &Setup::default()) {
            let _ = p.path(0.01);
            let _ = p.summary();
        }
    }
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    let text = format!("G0 X{}1{}\n", "[".repeat(100_000), "]".repeat(100_000));
    assert!(interpret("deep.ngc", &text, &Setup::default()).is_err());
    let text = format!("G0 X{}1\n", "-".repeat(100_000));
    assert!(interpret("deep.ngc", &text, &Setup::default()).is_err());
}
