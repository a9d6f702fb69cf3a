//! The oracle row of `acc compare` (`acc_sim::oracle`, docs/sim.md "The oracle row") is a
//! lower bound: no shipped law beats it on any shipped scenario, on the metrics the summary
//! computes; and on a constant-engagement cut its force RMS error is ~0 within the grid's
//! quantisation.

use acc_sim::oracle::oracle;
use acc_sim::workpiece::{Segment, SegmentKind};
use acc_sim::{LawKind, Scenario};

fn scenario(name: &str) -> Scenario {
    Scenario::load(acc_sim::run::configs_dir().join(format!("scenarios/{name}.toml")))
        .expect("scenario loads")
}

/// Every shipped scenario, by file stem.
fn shipped() -> Vec<String> {
    let dir = acc_sim::run::configs_dir().join("scenarios");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .expect("configs/scenarios")
        .filter_map(|e| {
            let p = e.ok()?.path();
            let stem = p.file_stem()?.to_string_lossy().into_owned();
            (p.extension()? == "toml").then_some(stem)
        })
        .collect();
    names.sort();
    names
}

/// On every shipped scenario, every law that cuts the part (its run finishes; a run ended
/// by the fault policy's feed hold did not cut it) has a force RMS error at or above the
/// oracle's; every law no slower than the constant safe feed has a peak at or above the
/// oracle's peak; every law whose true force never exceeded Fr takes at least the oracle's
/// cycle time.
#[test]
fn no_shipped_law_beats_the_oracle_on_any_shipped_scenario() {
    let mut checked = [0usize; 3];
    let mut worst = (f64::INFINITY, String::new());
    // The scenarios are independent: every law and the oracle of each, on two threads (the
    // slowest test of its binary); then every comparison, in scenario order.
    let names = shipped();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut computed: Vec<_> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..2)
            .map(|_| {
                scope.spawn(|| {
                    let mut mine = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                        let Some(name) = names.get(i) else {
                            return mine;
                        };
                        let sc = scenario(name);
                        let runs: Vec<_> = LawKind::ALL
                            .iter()
                            .map(|&k| sc.run_law(k).expect("law runs"))
                            .collect();
                        let fr = runs[0].1.force_ref_n;
                        let o = oracle(&sc, fr).expect("oracle");
                        mine.push((i, runs, fr, o));
                    }
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|w| w.join().expect("scenario worker"))
            .collect()
    });
    computed.sort_by_key(|c| c.0);
    for (i, runs, fr, o) in computed {
        let name = &names[i];
        // The fastest safe feed may not finish (a breakage that overloads at any feed): then
        // no law finishes with its force at or below Fr either.
        let o_cycle = o.safe.cycle_time_s.unwrap_or(f64::INFINITY);
        eprintln!(
            "{name}: oracle RMS {:.1} N, peak {:?} N (budget {:.1} s), cycle {:?}",
            o.rms.rms_error_cut_n, o.peak_n, o.peak_budget_s, o.safe.cycle_time_s
        );
        for (res, s) in &runs {
            let Some(cycle) = s.cycle_time_s else {
                continue;
            };
            let who = format!("{name} / {}", s.law);
            assert!(
                s.rms_error_cut_n >= o.rms.rms_error_cut_n,
                "{who}: RMS {:.2} N below the oracle's {:.2} N",
                s.rms_error_cut_n,
                o.rms.rms_error_cut_n
            );
            checked[0] += 1;
            let r = s.rms_error_cut_n / o.rms.rms_error_cut_n.max(1e-9);
            if r < worst.0 {
                worst = (r, who.clone());
            }
            if let Some(peak) = o.peak_n.filter(|_| cycle <= o.peak_budget_s + 1e-9) {
                assert!(
                    s.peak_force_n >= peak,
                    "{who}: peak {:.1} N below the oracle's {:.1} N (cycle {cycle:.1} s)",
                    s.peak_force_n,
                    peak
                );
                checked[1] += 1;
            }
            let true_peak = res
                .rows
                .iter()
                .filter_map(|r| r.force_true_n)
                .fold(0.0, f64::max);
            if true_peak <= fr {
                assert!(
                    cycle >= o_cycle - 1e-9,
                    "{who}: cycle {cycle:.1} s below the oracle's {o_cycle:.1} s at true peak {true_peak:.1} N"
                );
                checked[2] += 1;
            }
        }
    }
    eprintln!(
        "checked: {} RMS, {} peak, {} cycle comparisons; closest to the RMS bound: {} at {:.3}x",
        checked[0], checked[1], checked[2], worst.1, worst.0
    );
    assert!(checked[0] >= 60 && checked[1] >= 40, "{checked:?}");
}

/// A 3 mm cut of constant depth from the start of the path (the cutter starts in it) and
/// an air exit: every row in cut sees the same engagement, so the oracle's error is the
/// grid's quantisation only — at most half the force of one grid step, and ~0 when Fr is
/// itself the force at a grid position.
#[test]
fn on_a_constant_engagement_cut_the_oracle_rms_is_the_grid_quantisation() {
    let mut sc = scenario("paper_case3_dynamometer");
    // A tool that does not wear: the engagement and the process stay constant.
    sc.wear = acc_sim::process::WearSpec::default();
    let depth = 3.0;
    sc.workpiece.segments = vec![
        Segment {
            kind: SegmentKind::Cut,
            start_mm: 0.0,
            end_mm: 100.0,
            depth_start_mm: depth,
            depth_end_mm: depth,
            ks_factor: 1.0,
        },
        Segment {
            kind: SegmentKind::Air,
            start_mm: 100.0,
            end_mm: 120.0,
            depth_start_mm: 0.0,
            depth_end_mm: 0.0,
            ks_factor: 1.0,
        },
    ];
    let law = acc_sim::process::ForceLaw::new(sc.tool.process);
    let force_at = |pct: u16| {
        law.mean_force_n(
            depth,
            sc.workpiece.axial_depth_mm,
            sc.programmed_feed_mm_min * f64::from(pct) / 100.0,
            sc.machine.spindle.rpm,
            sc.wear.initial_factor,
        )
    };
    let step = sc.controller.override_spec.step_pct;
    let fr = sc.controller.force_ref_n;
    // Fr between grid positions: at most half a grid step of force.
    let half_step = 0.5 * (force_at(100 + step) - force_at(100));
    let o = oracle(&sc, fr).expect("oracle");
    let rms = o.rms.rms_error_cut_n;
    eprintln!("Fr {fr:.1} N: oracle RMS {rms:.2} N, half a grid step {half_step:.1} N");
    assert!(rms <= half_step, "{rms:.2} N > {half_step:.1} N");
    // Fr on a grid position (60 %): ~0 (the first period, the drive accelerating from
    // rest, is the only error).
    let on_grid = force_at(60);
    let o = oracle(&sc, on_grid).expect("oracle");
    let rms = o.rms.rms_error_cut_n;
    let settled = o.rms.segments[0].rms_error_n;
    eprintln!("Fr {on_grid:.1} N (60 %): oracle RMS {rms:.3} N, after settling {settled:.4} N");
    assert!(settled < 1e-3 * on_grid, "{settled:.4} N");
    // Over every row in cut: the first period (the drive starts from rest; the override
    // path's 16 ms delay and the 8 ms lag) is the only error, about a quarter of Fr over
    // ~500 rows.
    assert!(rms < 0.015 * on_grid, "{rms:.3} N");
    // The fastest safe feed is that grid position, and never exceeds Fr.
    assert!(o.safe.peak_force_n <= on_grid + 1e-6);
}
