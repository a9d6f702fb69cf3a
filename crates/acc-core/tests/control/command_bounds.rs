//! The one quantization step with the policy's bounds ([`OverrideSpec::place`],
//! [`CommandBounds`]): a tool limit or a plan cap below the law's command is written on the
//! board's grid and re-seats the law's integrator on it; the guards (invalid sample, knob)
//! bound the command without re-seating; and `Controller::step_within` gives exactly what
//! stepping the law and then bounding its command gives, for every quantizer.
#![allow(clippy::unwrap_used)]

use crate::common::PROGRAMMED;
use acc_core::{
    CommandBounds, CommandLimits, Controller, ControllerConfig, Demand, FeedOverride, Measurement,
    OverrideLaw, OverrideSpec, PaperCase, Quantizer, SigmaDelta,
};
use proptest::prelude::*;

/// The paper's range on a 10 % board, no guards, `limits`.
fn bounds(limits: CommandLimits) -> CommandBounds {
    CommandBounds {
        grid: OverrideSpec::range(0, 150).on_grid(10),
        valid: true,
        hold_pct: None,
        knob_pct: None,
        limits,
    }
}

fn cap(pct: u16) -> CommandLimits {
    CommandLimits {
        cap_pct: Some(pct),
        floor_pct: None,
    }
}

#[test]
fn a_tool_limit_below_the_laws_command_is_floored_onto_the_grid_and_reseats() {
    let p = bounds(cap(87)).place(FeedOverride(120));
    assert_eq!(
        (p.law, p.cmd, p.reseat),
        (FeedOverride(120), FeedOverride(80), true)
    );
    // A cap above the command changes nothing.
    let p = bounds(cap(135)).place(FeedOverride(120));
    assert_eq!((p.cmd, p.reseat), (FeedOverride(120), false));
}

#[test]
fn a_plan_cap_wins_over_the_entry_floor_and_the_floor_needs_a_valid_sample() {
    let both = CommandLimits {
        cap_pct: Some(54),
        floor_pct: Some(71),
    };
    // The floor ceils 71 → 80, then the cap floors 54 → 50: the cap is applied last.
    let p = bounds(both).place(FeedOverride(30));
    assert_eq!((p.cmd, p.reseat), (FeedOverride(50), true));
    let floor = CommandLimits {
        cap_pct: None,
        floor_pct: Some(71),
    };
    assert_eq!(bounds(floor).place(FeedOverride(30)).cmd, FeedOverride(80));
    let invalid = CommandBounds {
        valid: false,
        hold_pct: Some(40),
        ..bounds(floor)
    };
    let p = invalid.place(FeedOverride(30));
    assert_eq!((p.cmd, p.reseat), (FeedOverride(30), false));
}

#[test]
fn a_floor_never_lifts_the_command_above_the_operators_knob() {
    // The shop layer's (or the plan's lead's) floor at 71 % → 80 % on the grid; the
    // operator's knob at 55 %: the knob wins (50 % on the grid).
    let b = CommandBounds {
        knob_pct: Some(55),
        ..bounds(CommandLimits {
            cap_pct: None,
            floor_pct: Some(71),
        })
    };
    assert_eq!(b.place(FeedOverride(30)).cmd, FeedOverride(50));
    assert_eq!(b.place(FeedOverride(120)).cmd, FeedOverride(50));
    // A knob above the floor leaves the floor acting.
    let b = CommandBounds {
        knob_pct: Some(95),
        ..b
    };
    assert_eq!(b.place(FeedOverride(30)).cmd, FeedOverride(80));
}

#[test]
fn the_guards_bound_the_command_without_reseating() {
    let knob = CommandBounds {
        knob_pct: Some(75),
        ..bounds(CommandLimits::default())
    };
    let p = knob.place(FeedOverride(120));
    assert_eq!((p.cmd, p.reseat), (FeedOverride(70), false));
    let held = CommandBounds {
        valid: false,
        hold_pct: Some(60),
        ..bounds(CommandLimits::default())
    };
    let p = held.place(FeedOverride(90));
    assert_eq!((p.cmd, p.reseat), (FeedOverride(60), false));
    // The configured range on a coarser board floors the law's position (never raises it).
    let grid = CommandBounds {
        grid: OverrideSpec::range(20, 130).on_grid(25),
        ..bounds(CommandLimits::default())
    };
    assert_eq!(grid.place(FeedOverride(120)).cmd, FeedOverride(100));
    assert_eq!(grid.place(FeedOverride(10)).cmd, FeedOverride(25));
}

#[test]
fn place_without_bounds_is_the_laws_own_quantizer() {
    let spec = OverrideSpec::paper().with_hysteresis(3.0);
    let mut sd = SigmaDelta::new();
    let prev = FeedOverride(60);
    let p = spec.place(Demand::Within(67.9), prev, &mut sd, None);
    assert_eq!((p.law, p.cmd, p.reseat), (prev, prev, false));
    let p = spec.place(Demand::Within(68.0), prev, &mut sd, None);
    assert_eq!(p.cmd, FeedOverride(70));
    assert_eq!(spec.place(Demand::Held, prev, &mut sd, None).cmd, prev);
    let sdspec = OverrideSpec::paper().with_quantizer(Quantizer::SigmaDelta);
    sdspec.place(Demand::Within(64.0), prev, &mut sd, None);
    assert!(sd.residue_pct() != 0.0);
    let p = sdspec.place(Demand::Saturated(FeedOverride(150)), prev, &mut sd, None);
    assert_eq!(p.cmd, FeedOverride(150));
    assert_eq!(sd.residue_pct(), 0.0, "a limit resets the dither");
}

/// An air cut (no force) drives the law up against a cap of `cap_pct` for `capped`
/// periods; then the cap is lifted in the cut (Kc = 4 N/(mm/min): Fr = 800 N at 100 %).
/// `within`: the cap in the law's quantization step (`step_within`); otherwise clamped
/// after the law, which is not told. Returns the commands written.
fn air_cut_under_a_cap(cap_pct: u16, capped: usize, within: bool) -> Vec<u16> {
    let mut ctl = Controller::new(ControllerConfig::paper_case(PaperCase::III)).unwrap();
    ctl.engage(FeedOverride(60));
    let mut feed = 0.6 * PROGRAMMED;
    let mut out = Vec::new();
    for i in 0..capped + 3 {
        let (force, limits) = if i < capped {
            (0.0, cap(cap_pct))
        } else {
            (4.0 * feed, CommandLimits::default())
        };
        let m = Measurement {
            force_n: force,
            feed_mm_min: feed,
            programmed_feed_mm_min: PROGRAMMED,
            valid: true,
        };
        let cmd = if within {
            ctl.step_within(&m, &bounds(limits)).command
        } else {
            let o = ctl.step(&m).command;
            FeedOverride(o.0.min(limits.cap_pct.unwrap_or(u16::MAX) / 10 * 10))
        };
        feed = cmd.feed_mm_min(PROGRAMMED);
        out.push(cmd.0);
    }
    out
}

#[test]
fn a_capped_law_is_reseated_on_the_cap_and_does_not_wind_up_against_it() {
    let cmds = air_cut_under_a_cap(87, 30, true);
    // Under the cap: 80 % written every period once the law reaches it.
    assert!(cmds[..30].iter().all(|c| *c <= 80), "{cmds:?}");
    assert_eq!(cmds[29], 80);
    // The cap lifted in the cut: the law starts from the cap and settles at Fr (100 %),
    // never above it.
    assert!(
        cmds[30..].iter().all(|c| (80..=100).contains(c)),
        "{cmds:?}"
    );
    assert_eq!(cmds.last(), Some(&100));
    // A law not told of the cap integrates 30 periods of air-cut error against it and
    // jumps to the top of the range when it is lifted.
    let blind = air_cut_under_a_cap(87, 30, false);
    assert_eq!(blind[30], 150, "{blind:?}");
}

fn spec_of(q: u8) -> OverrideSpec {
    match q {
        0 => OverrideSpec::paper(),
        1 => OverrideSpec::paper().with_hysteresis(4.0),
        _ => OverrideSpec::paper().with_quantizer(Quantizer::SigmaDelta),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    /// `Controller::step_within` (the bounds inside the one quantization step) equals the
    /// law's step followed by the bounds and a re-engage when they changed the command —
    /// command, integrator and last command, every period, for the three quantizers.
    #[test]
    fn step_within_is_the_step_then_the_bounds(
        q in 0u8..3,
        periods in proptest::collection::vec(
            (0.0f64..2000.0, any::<bool>(), proptest::option::of(0u16..160),
             proptest::option::of(0u16..160), proptest::option::of(0u16..160), 0u16..150),
            1..80),
    ) {
        let mut cfg = ControllerConfig::paper_case(PaperCase::III);
        cfg.override_spec = spec_of(q);
        let mut a = Controller::new(cfg).unwrap();
        let mut b = Controller::new(cfg).unwrap();
        a.engage(FeedOverride(100));
        b.engage(FeedOverride(100));
        let mut feed = PROGRAMMED;
        for (i, (force, valid, cap_pct, floor_pct, knob, last)) in periods.into_iter().enumerate() {
            let m = Measurement { force_n: force, feed_mm_min: feed,
                                  programmed_feed_mm_min: PROGRAMMED, valid };
            let bd = CommandBounds {
                grid: OverrideSpec::range(0, 150).on_grid(10),
                valid,
                hold_pct: (!valid).then_some(last),
                knob_pct: knob,
                limits: CommandLimits { cap_pct, floor_pct },
            };
            let oa = a.step_within(&m, &bd);
            let ob = b.step(&m);
            let placed = bd.place(ob.command);
            if placed.reseat {
                b.engage(placed.cmd);
            }
            prop_assert_eq!(oa.command, placed.cmd, "period {}", i);
            prop_assert_eq!(oa.trace, ob.trace, "period {}", i);
            prop_assert_eq!(a.last_command(), b.last_command(), "period {}", i);
            prop_assert_eq!(a.integral_mm_min().to_bits(), b.integral_mm_min().to_bits());
            feed = oa.command.feed_mm_min(PROGRAMMED);
        }
    }
}
