//! The twin's lab: the evaluation and development commands of the model-discrepancy
//! workflow in one binary (one build and link instead of ten). The first argument names
//! the command; the rest are its own arguments:
//!
//! ```sh
//! cargo run --release -p acc-ident --example twin_lab -- COMMAND [ARGS…]
//! ```
//!
//! | command | what it does |
//! | --- | --- |
//! | `twin_eval` | the honest twin's evaluation (docs/twin-evaluation.md) |
//! | `sweep` | the full hidden-effect sweep on synthetic logs |
//! | `discrepancy_speed` | speed of `acc discrepancy` on a 10-minute production log |
//! | `realdata` | the workflow on the real data in `../shared/data` |
//! | `motor_mismatch` | power logs against a constant-efficiency spindle model |
//! | `one` | one synthetic hidden-effect case with its candidate table |
//! | `twin_one` | one evaluation case end to end |
//! | `twin_probe` | replay residual of null logs from `acc sim` |
//! | `twin_resid` | residual of the nominal replay of one null log, row by row |
//! | `log_resid` | residual of the nominal replay of a run log file, row by row |

mod discrepancy_speed;
mod log_resid;
mod motor_mismatch;
mod one;
mod realdata;
mod sweep;
mod twin_eval;
mod twin_one;
mod twin_probe;
mod twin_resid;

/// The commands, in the table's order.
const COMMANDS: [&str; 10] = [
    "twin_eval",
    "sweep",
    "discrepancy_speed",
    "realdata",
    "motor_mismatch",
    "one",
    "twin_one",
    "twin_probe",
    "twin_resid",
    "log_resid",
];

/// The command's arguments as `std::env::args()` would give them to a binary of its own:
/// the program name, then everything after the command's name.
fn args() -> std::vec::IntoIter<String> {
    let mut all: Vec<String> = std::env::args().collect();
    if all.len() > 1 {
        all.remove(1);
    }
    all.into_iter()
}

/// A command's case arguments `WORKPIECE … CHANNEL SEED`, the channel and the seed at
/// positions `at` and `at + 1`: the workpiece file (default `interrupted.toml`), the
/// channel (`power`, else force) and the seed (default 1000).
fn case_args(a: &[String], at: usize) -> (String, acc_ident::model::Channel, u64) {
    let wp = a
        .first()
        .cloned()
        .unwrap_or_else(|| "interrupted.toml".into());
    let ch = if a.get(at).map(String::as_str) == Some("power") {
        acc_ident::model::Channel::Power
    } else {
        acc_ident::model::Channel::Force
    };
    let seed = a.get(at + 1).and_then(|s| s.parse().ok()).unwrap_or(1000);
    (wp, ch, seed)
}

fn main() {
    let command = std::env::args().nth(1).unwrap_or_default();
    match command.as_str() {
        "twin_eval" => twin_eval::main(),
        "sweep" => sweep::main(),
        "discrepancy_speed" => discrepancy_speed::main(),
        "realdata" => realdata::main(),
        "motor_mismatch" => motor_mismatch::main(),
        "one" => {
            if let Err(e) = one::main() {
                eprintln!("one: {e}");
                std::process::exit(1);
            }
        }
        "twin_one" => twin_one::main(),
        "twin_probe" => twin_probe::main(),
        "twin_resid" => twin_resid::main(),
        "log_resid" => log_resid::main(),
        other => {
            eprintln!(
                "twin_lab: unknown command {other:?}; allowed: {}",
                COMMANDS.join(", ")
            );
            std::process::exit(2);
        }
    }
}
