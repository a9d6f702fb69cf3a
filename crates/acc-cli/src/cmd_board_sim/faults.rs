//! The faults `acc board-sim --fault KIND@T[:ARG]` schedules (see the module docs of
//! `acc board-sim` for each kind).

use std::time::Duration;

/// A fault on the replies the board sends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum ReplyFault {
    Crc,
    Drop,
    Late(Duration),
    Stall(Duration),
}

/// A scheduled fault.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Scheduled {
    Replies(ReplyFault, usize),
    Restart,
    FreezeSeq(f64),
    BadPower(f64),
    Lock(f64),
    Switch(bool),
    Operator(u16),
    /// The cable is pulled, for good (`None`) or for this many machine seconds.
    Unplug(Option<f64>),
    /// The device disappears: the pty is closed.
    Vanish,
    /// A hard spot: `Ks` × factor for this many machine seconds.
    Hard(f64, f64),
}

impl Scheduled {
    /// The fault stops the controller's requests from reaching the board (or the board's
    /// serving them), so that no command write would move a machine paced by them.
    pub(super) fn silences_controller(&self) -> bool {
        matches!(
            self,
            Scheduled::Unplug(_) | Scheduled::Vanish | Scheduled::Replies(ReplyFault::Stall(_), _)
        )
    }
}

pub(super) fn parse_fault(spec: &str, late: Duration) -> anyhow::Result<(f64, Scheduled)> {
    let err = || {
        anyhow::anyhow!(
            "--fault `{spec}`: expected KIND@T[:ARG] with KIND one of crc, drop, late, restart, freeze-seq, bad-power, lock, stall, switch, operator, knob, unplug, vanish, hard (T in machine seconds; hard@T:S:F)"
        )
    };
    let (kind, rest) = spec.split_once('@').ok_or_else(err)?;
    let (t, arg) = match rest.split_once(':') {
        Some((t, a)) => (t, Some(a)),
        None => (rest, None),
    };
    let t: f64 = t.parse().map_err(|_| err())?;
    if !(t.is_finite() && t >= 0.0) {
        return Err(err());
    }
    let count = || -> anyhow::Result<usize> {
        arg.unwrap_or("1")
            .parse::<usize>()
            .ok()
            .filter(|n| (1..=10_000).contains(n))
            .ok_or_else(err)
    };
    let secs = || -> anyhow::Result<f64> {
        arg.and_then(|a| a.parse::<f64>().ok())
            .filter(|s| s.is_finite() && *s > 0.0 && *s <= 3600.0)
            .ok_or_else(err)
    };
    let f = match kind {
        "crc" => Scheduled::Replies(ReplyFault::Crc, count()?),
        "drop" => Scheduled::Replies(ReplyFault::Drop, count()?),
        "late" => Scheduled::Replies(ReplyFault::Late(late), count()?),
        "stall" => Scheduled::Replies(ReplyFault::Stall(Duration::from_secs_f64(secs()?)), 1),
        "restart" => Scheduled::Restart,
        "freeze-seq" => Scheduled::FreezeSeq(secs()?),
        "bad-power" => Scheduled::BadPower(secs()?),
        "lock" => Scheduled::Lock(secs()?),
        "switch" => match arg {
            Some("on") => Scheduled::Switch(true),
            Some("off") => Scheduled::Switch(false),
            _ => return Err(err()),
        },
        "unplug" => Scheduled::Unplug(match arg {
            None => None,
            Some(_) => Some(secs()?),
        }),
        "vanish" => Scheduled::Vanish,
        "hard" => {
            let (secs, factor) = arg.and_then(|a| a.split_once(':')).ok_or_else(err)?;
            let secs: f64 = secs.parse().map_err(|_| err())?;
            let factor: f64 = factor.parse().map_err(|_| err())?;
            let secs_ok = secs.is_finite() && secs > 0.0 && secs <= 3600.0;
            let factor_ok = factor.is_finite() && factor > 0.0 && factor <= 20.0;
            if !(secs_ok && factor_ok) {
                return Err(err());
            }
            Scheduled::Hard(secs, factor)
        }
        "operator" | "knob" => Scheduled::Operator(
            arg.and_then(|a| a.parse::<u16>().ok())
                .filter(|p| *p <= 150)
                .ok_or_else(err)?,
        ),
        _ => return Err(err()),
    };
    Ok((t, f))
}

#[cfg(test)]
mod tests {
    use super::*;

    const LATE: Duration = Duration::from_millis(60);

    #[test]
    fn unplug_and_knob_faults_parse() {
        assert_eq!(
            parse_fault("unplug@12.5", LATE).expect("for good"),
            (12.5, Scheduled::Unplug(None))
        );
        assert_eq!(
            parse_fault("unplug@3:2", LATE).expect("for 2 s"),
            (3.0, Scheduled::Unplug(Some(2.0)))
        );
        assert_eq!(
            parse_fault("knob@4:60", LATE).expect("knob"),
            (4.0, Scheduled::Operator(60))
        );
        assert_eq!(
            parse_fault("restart@7", LATE).expect("restart"),
            (7.0, Scheduled::Restart)
        );
        assert_eq!(
            parse_fault("vanish@9", LATE).expect("vanish"),
            (9.0, Scheduled::Vanish)
        );
        assert_eq!(
            parse_fault("hard@40:2:2.5", LATE).expect("hard"),
            (40.0, Scheduled::Hard(2.0, 2.5))
        );
        for bad in [
            "hard@40:2",
            "hard@40:0:2",
            "hard@40:2:0",
            "hard@40:2:21",
            "hard@40:x:2",
            "unplug@3:0",
            "unplug@3:-1",
            "unplug@3:x",
            "knob@1:151",
            "knob@1",
            "plug@1",
        ] {
            let e = parse_fault(bad, LATE).expect_err(bad).to_string();
            assert!(e.contains(bad) && e.contains("unplug"), "{bad}: {e}");
        }
    }

    #[test]
    fn only_the_faults_that_silence_the_controller_refuse_its_pace() {
        for (spec, silences) in [
            ("unplug@3", true),
            ("unplug@3:2", true),
            ("vanish@3", true),
            ("stall@3:1", true),
            ("crc@3:2", false),
            ("drop@3:2", false),
            ("late@3:2", false),
            ("restart@3", false),
            ("operator@3:80", false),
            ("hard@3:2:2", false),
        ] {
            let (_, f) = parse_fault(spec, LATE).expect(spec);
            assert_eq!(f.silences_controller(), silences, "{spec}");
        }
    }
}
