//! What `acc soak` runs: the scenario with its workpiece repeated for the soak's length,
//! the seeded random fault schedule with the operator's re-arms, and the hostile line's
//! delay episodes.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use rand::{Rng, SeedableRng};

/// The hostile line's delay episodes: (on, off) in machine time, each ending at least 15 s
/// before the end (the last re-arm is at 10 s before the end).
pub fn delay_episodes(machine_s: f64, every_s: f64, for_s: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut t = every_s;
    while t + for_s <= machine_s - 15.0 {
        out.push((t, t + for_s));
        t += every_s;
    }
    out
}

/// The scenario with its workpiece repeated for `machine_s` (paths made absolute).
pub fn write_soak_scenario(base: &Path, out: &Path, machine_s: f64) -> anyhow::Result<PathBuf> {
    let text =
        std::fs::read_to_string(base).with_context(|| format!("reading {}", base.display()))?;
    let mut sc: toml::Table =
        toml::from_str(&text).with_context(|| format!("parsing {}", base.display()))?;
    let dir = base
        .parent()
        .unwrap_or(Path::new("."))
        .canonicalize()
        .with_context(|| format!("folder of {}", base.display()))?;
    for key in ["machine", "tool", "controller"] {
        if let Some(toml::Value::String(p)) = sc.get(key) {
            let abs = dir.join(p);
            sc.insert(key.into(), abs.to_string_lossy().into_owned().into());
        }
    }
    let wp_rel = match sc.get("workpiece") {
        Some(toml::Value::String(p)) => p.clone(),
        _ => bail!("{}: no `workpiece` path to repeat", base.display()),
    };
    let wp_path = dir.join(&wp_rel);
    let wp_text = std::fs::read_to_string(&wp_path)
        .with_context(|| format!("reading {}", wp_path.display()))?;
    let wp: toml::Table =
        toml::from_str(&wp_text).with_context(|| format!("parsing {}", wp_path.display()))?;
    let segments = match wp.get("segment") {
        Some(toml::Value::Array(a)) if !a.is_empty() => a.clone(),
        _ => bail!("{}: no [[segment]] to repeat", wp_path.display()),
    };
    // One pass of case III takes about 60 s; repeat with margin (a pass never takes less
    // than 20 s at 150 %).
    let repeats = (machine_s / 20.0).ceil() as usize + 2;
    let mut all = Vec::with_capacity(segments.len() * repeats);
    for _ in 0..repeats {
        all.extend(segments.iter().cloned());
    }
    let mut soak_wp = wp.clone();
    soak_wp.insert(
        "name".into(),
        format!(
            "soak: {} x {}",
            repeats,
            wp.get("name")
                .and_then(|v| v.as_str())
                .unwrap_or("workpiece")
        )
        .into(),
    );
    soak_wp.insert("segment".into(), toml::Value::Array(all));
    let wp_out = out.join("soak_workpiece.toml");
    std::fs::write(&wp_out, toml::to_string(&soak_wp)?)?;
    sc.insert(
        "workpiece".into(),
        wp_out.canonicalize()?.to_string_lossy().into_owned().into(),
    );
    sc.insert("max_time_s".into(), toml::Value::Float(machine_s + 600.0));
    sc.insert("name".into(), "soak".into());
    let sc_out = out.join("soak_scenario.toml");
    std::fs::write(&sc_out, toml::to_string(&sc)?)?;
    Ok(sc_out)
}

/// The operator re-arms once more near the end (switch off, on half a second later).
pub fn final_rearm(at: f64) -> [String; 2] {
    [
        format!("switch@{at:.1}:off"),
        format!("switch@{:.1}:on", at + 0.5),
    ]
}

/// The random fault schedule: `acc board-sim --fault` specs, each followed by the
/// operator re-arming ACC (switch off, on).
pub fn fault_schedule(seed: u64, machine_s: f64, every_s: f64) -> Vec<String> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    let mut t = 30.0;
    while t < machine_s - 30.0 {
        let tt = format!("{t:.1}");
        match rng.random_range(0..10) {
            0 => out.push(format!("crc@{tt}:{}", rng.random_range(1..30))),
            1 => out.push(format!("drop@{tt}:{}", rng.random_range(1..30))),
            2 => out.push(format!("late@{tt}:{}", rng.random_range(1..30))),
            3 => out.push(format!("freeze-seq@{tt}:{:.1}", rng.random_range(0.3..3.0))),
            4 => out.push(format!("bad-power@{tt}:{:.1}", rng.random_range(0.3..3.0))),
            5 => out.push(format!("restart@{tt}")),
            6 => out.push(format!("lock@{tt}:{:.1}", rng.random_range(0.3..3.0))),
            7 => {
                out.push(format!("operator@{tt}:{}", 10 * rng.random_range(5..10)));
                out.push(format!("operator@{:.1}:100", t + 2.0));
            }
            8 => out.push(format!(
                "hard@{tt}:{:.1}:{:.2}",
                rng.random_range(0.5..3.0),
                rng.random_range(1.2..2.5)
            )),
            _ => out.push(format!("unplug@{tt}:{:.1}", rng.random_range(0.5..3.0))),
        }
        // The operator re-arms a latched release: switch off, and on 0.5 s later (while
        // off, the cut runs at the knob: the operator's own act, not a fault).
        out.push(format!("switch@{:.1}:off", t + 3.5));
        out.push(format!("switch@{:.1}:on", t + 4.0));
        t += 4.5 + rng.random_range(0.5 * every_s..1.5 * every_s);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_is_seeded_and_re_arms_after_every_fault() {
        let a = fault_schedule(7, 600.0, 5.0);
        assert_eq!(a, fault_schedule(7, 600.0, 5.0));
        assert_ne!(a, fault_schedule(8, 600.0, 5.0));
        let faults = a.iter().filter(|f| !f.starts_with("switch@")).count();
        let offs = a.iter().filter(|f| f.ends_with(":off")).count();
        assert!(faults >= 50, "{faults} faults in 600 s");
        assert_eq!(offs, a.iter().filter(|f| f.ends_with(":on")).count());
        // Every spec has a time in the run.
        for f in &a {
            let t: f64 = f
                .split('@')
                .nth(1)
                .and_then(|r| r.split(':').next())
                .and_then(|t| t.parse().ok())
                .unwrap_or(-1.0);
            assert!((30.0..600.0).contains(&t), "{f}");
        }
    }

    #[test]
    fn delay_episodes_end_before_the_last_re_arm() {
        assert_eq!(
            delay_episodes(200.0, 60.0, 10.0),
            vec![(60.0, 70.0), (120.0, 130.0)]
        );
        assert_eq!(delay_episodes(3600.0, 180.0, 10.0).len(), 19);
        assert!(delay_episodes(100.0, 180.0, 10.0).is_empty());
        assert_eq!(
            final_rearm(190.0),
            [
                "switch@190.0:off".to_string(),
                "switch@190.5:on".to_string()
            ]
        );
    }
}
