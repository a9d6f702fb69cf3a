//! One evaluation case end to end (development aid): workpiece, hidden effect label,
//! channel, seed → the verdict and the time it took.
//!
//! cargo run --release -p acc-ident --example twin_lab -- twin_one interrupted.toml null force 1007
use acc_ident::twin::{run_case, Hidden};

pub fn main() {
    let a: Vec<String> = crate::args().skip(1).collect();
    let (wp, ch, seed) = crate::case_args(&a, 2);
    let h = a.get(1).cloned().unwrap_or_else(|| "null".into());
    let hidden = Hidden::parse(&h).expect("hidden effect label");
    let dir = acc_sim::run::configs_dir();
    let mut sc = acc_sim::Scenario::load(dir.join("scenarios/paper_case3.toml")).expect("sc");
    sc.workpiece = acc_sim::Workpiece::load(dir.join("workpieces").join(&wp)).expect("wp");
    sc.max_time_s = 60.0;
    let t = std::time::Instant::now();
    let mut s2 = sc.clone();
    s2.seed = seed;
    let log = acc_ident::twin::simulate(&s2).expect("sim");
    println!(
        "simulate: {:.2} s, {} rows",
        t.elapsed().as_secs_f64(),
        log.len()
    );
    let t = std::time::Instant::now();
    let v = run_case(&sc, hidden, ch, seed).expect("case");
    if std::env::var_os("TWIN_EXPLAIN").is_some() {
        for l in &v.explanation {
            println!("  {l}");
        }
    }
    println!(
        "{wp} {} {ch:?} {seed}: {v:?} ({:.1} s)",
        hidden.label(),
        t.elapsed().as_secs_f64()
    );
}
