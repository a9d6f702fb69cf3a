//! Development aid: one hidden-effect case with the candidate table.
//! `cargo run --release -p acc-ident --example twin_lab -- one <effect> <enr> <rho> <seed>`
use acc_ident::synth::{self, Case, Hidden};
use acc_ident::{workflow, EffectKind};

pub fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = crate::args().collect();
    let kind = EffectKind::from_name(a.get(1).map(String::as_str).unwrap_or("tool_wear"))
        .ok_or("effect")?;
    let enr: f64 = a.get(2).and_then(|s| s.parse().ok()).unwrap_or(4.0);
    let rho: f64 = a.get(3).and_then(|s| s.parse().ok()).unwrap_or(0.0);
    let seed: u64 = a.get(4).and_then(|s| s.parse().ok()).unwrap_or(1);
    let c = Case {
        duration_s: 120.0,
        rpm: 450.0,
        noise_rho: rho,
        continuous: std::env::var("CONT").is_ok(),
        ..Case::default()
    };
    let h = Hidden {
        kind,
        value: synth::value_for_enr(&c, kind, enr, seed),
    };
    let (m, log, _) = synth::generate(&c, &[h], seed);
    let an = workflow::analyse(&m, &log, &workflow::Options::default())?;
    println!(
        "hidden {} = {:.4}\n{}",
        kind.name(),
        h.value,
        an.report.to_markdown()
    );
    Ok(())
}
