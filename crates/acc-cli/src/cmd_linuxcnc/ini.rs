//! `acc linuxcnc --ini SECTION.KEY=VALUE`: LinuxCNC configuration values the model is not
//! told (an axis's acceleration, the planner's), set in the generated `acc.ini`. The
//! section and the key must exist in the template; a number is checked against the
//! range of its kind. On trivial kinematics (`trivkins`, joints 0, 1, 2 = X, Y, Z) an
//! `AXIS_<L>` limit is also written into its `JOINT_<n>` section: LinuxCNC 2.9 plans
//! coordinated moves with the axis's limit and checks the joint's, which must not be lower.

/// One `--ini` value: section, key, value.
#[derive(Debug, Clone, PartialEq)]
pub struct IniValue {
    /// The section, without brackets (`AXIS_X`).
    pub section: String,
    /// The key (`MAX_ACCELERATION`).
    pub key: String,
    /// The value as written.
    pub value: String,
}

/// The joint of an axis under `trivkins` (X, Y, Z = joints 0, 1, 2).
fn joint_of(section: &str) -> Option<&'static str> {
    match section {
        "AXIS_X" => Some("JOINT_0"),
        "AXIS_Y" => Some("JOINT_1"),
        "AXIS_Z" => Some("JOINT_2"),
        _ => None,
    }
}

/// Keys an axis shares with its joint.
const JOINT_KEYS: [&str; 4] = ["MAX_ACCELERATION", "MAX_VELOCITY", "MIN_LIMIT", "MAX_LIMIT"];

/// The allowed range of a numeric key, by its name: accelerations mm/s², velocities mm/s,
/// limits mm; `None` for a key of no known kind (any finite number).
fn range_of(key: &str) -> Option<(f64, f64, &'static str)> {
    if key.ends_with("ACCELERATION") {
        Some((1.0, 100_000.0, "mm/s²"))
    } else if key.ends_with("VELOCITY") {
        Some((0.1, 10_000.0, "mm/s"))
    } else if key.ends_with("LIMIT") {
        Some((-100_000.0, 100_000.0, "mm"))
    } else {
        None
    }
}

/// `SECTION.KEY=VALUE` split, or an error naming the option.
pub fn parse(spec: &str) -> anyhow::Result<IniValue> {
    let bad = || {
        anyhow::anyhow!("--ini {spec}: expected SECTION.KEY=VALUE, e.g. AXIS_X.MAX_ACCELERATION=50")
    };
    let (name, value) = spec.split_once('=').ok_or_else(bad)?;
    let (section, key) = name.split_once('.').ok_or_else(bad)?;
    let (section, key, value) = (section.trim(), key.trim(), value.trim());
    if section.is_empty() || key.is_empty() || value.is_empty() || value.contains('\n') {
        return Err(bad());
    }
    Ok(IniValue {
        section: section.to_string(),
        key: key.to_string(),
        value: value.to_string(),
    })
}

/// The line index of `key` in `[section]` of `lines`.
fn find(lines: &[String], section: &str, key: &str) -> Result<usize, &'static str> {
    let header = format!("[{section}]");
    let start = lines
        .iter()
        .position(|l| l.trim() == header)
        .ok_or("no such section")?;
    lines[start + 1..]
        .iter()
        .take_while(|l| !l.trim_start().starts_with('['))
        .position(|l| {
            l.split_once('=')
                .is_some_and(|(k, _)| k.trim() == key && !l.trim_start().starts_with('#'))
        })
        .map(|i| start + 1 + i)
        .ok_or("no such key in the section")
}

/// `v` checked against the template's value at `old` (a number stays a number, in the
/// key's range).
fn check_value(spec: &str, v: &IniValue, old: &str) -> anyhow::Result<()> {
    if old.parse::<f64>().is_err() {
        return Ok(());
    }
    let x: f64 = v
        .value
        .parse()
        .map_err(|_| anyhow::anyhow!("--ini {spec}: `{}` is not a number", v.value))?;
    if !x.is_finite() {
        anyhow::bail!("--ini {spec}: `{}` is not a finite number", v.value);
    }
    if let Some((lo, hi, unit)) = range_of(&v.key) {
        if !(lo..=hi).contains(&x) {
            anyhow::bail!(
                "--ini {spec}: {}.{} = {x}: allowed {lo} ..= {hi} {unit}",
                v.section,
                v.key
            );
        }
    }
    Ok(())
}

/// `text` (an INI) with every value of `values` set, each also in its joint's section
/// (see the module); an error names the option, the section and key, or the range.
pub fn apply(text: &str, values: &[IniValue]) -> anyhow::Result<String> {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    for v in values {
        let spec = format!("{}.{}={}", v.section, v.key, v.value);
        let at = find(&lines, &v.section, &v.key).map_err(|why| {
            anyhow::anyhow!(
                "--ini {spec}: {why} in the template acc.ini ([{}] {})",
                v.section,
                v.key
            )
        })?;
        let old = lines[at].split_once('=').map_or("", |(_, o)| o.trim());
        check_value(&spec, v, old)?;
        lines[at] = format!("{} = {}", v.key, v.value);
        let joint = joint_of(&v.section).filter(|_| JOINT_KEYS.contains(&v.key.as_str()));
        if let Some(joint) = joint {
            if let Ok(j) = find(&lines, joint, &v.key) {
                lines[j] = format!("{} = {}", v.key, v.value);
            }
        }
    }
    let mut out = lines.join("\n");
    out.push('\n');
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const INI: &str = "[TRAJ]\nMAX_LINEAR_ACCELERATION = 500\n[AXIS_X]\nMAX_ACCELERATION = 500\n# MAX_VELOCITY = 3\nMAX_VELOCITY = 100\n[AXIS_Y]\nMAX_ACCELERATION = 500\n[JOINT_0]\nMAX_ACCELERATION = 500\n[DISPLAY]\nDISPLAY = ./ui.py\n";

    #[test]
    fn a_value_is_set_in_its_section_and_its_joint() {
        let v = parse("AXIS_X.MAX_ACCELERATION=50").expect("parse");
        let out = apply(INI, &[v]).expect("apply");
        assert!(out.contains("[AXIS_X]\nMAX_ACCELERATION = 50\n"), "{out}");
        assert!(out.contains("[JOINT_0]\nMAX_ACCELERATION = 50\n"), "{out}");
        // The other axis, the planner and the comment are left alone.
        assert!(out.contains("[AXIS_Y]\nMAX_ACCELERATION = 500\n"), "{out}");
        assert!(out.contains("MAX_LINEAR_ACCELERATION = 500"), "{out}");
        let v = parse("AXIS_X.MAX_VELOCITY = 20").expect("parse");
        let out = apply(INI, &[v]).expect("apply");
        assert!(
            out.contains("# MAX_VELOCITY = 3\nMAX_VELOCITY = 20\n"),
            "{out}"
        );
    }

    #[test]
    fn a_bad_value_names_the_option_and_what_is_allowed() {
        for (spec, says) in [
            ("AXIS_X.MAX_ACCELERATION", "expected SECTION.KEY=VALUE"),
            ("MAX_ACCELERATION=5", "expected SECTION.KEY=VALUE"),
            ("AXIS_X.MAX_ACCELERATION=", "expected SECTION.KEY=VALUE"),
        ] {
            let e = parse(spec).expect_err(spec).to_string();
            assert!(e.contains(says) && e.contains("--ini"), "{spec}: {e}");
        }
        for (spec, says) in [
            ("AXIS_A.MAX_ACCELERATION=5", "no such section"),
            ("AXIS_X.MAX_JERK=5", "no such key"),
            ("AXIS_X.MAX_ACCELERATION=fast", "not a number"),
            ("AXIS_X.MAX_ACCELERATION=0.5", "allowed 1 ..= 100000 mm/s²"),
            ("AXIS_X.MAX_ACCELERATION=inf", "not a finite number"),
            ("AXIS_X.MAX_VELOCITY=0", "allowed 0.1 ..= 10000 mm/s"),
        ] {
            let v = parse(spec).expect(spec);
            let e = apply(INI, &[v]).expect_err(spec).to_string();
            assert!(e.contains(says) && e.contains(spec), "{spec}: {e}");
        }
        // A text value takes any text.
        let v = parse("DISPLAY.DISPLAY=./other.py").expect("parse");
        assert!(apply(INI, &[v])
            .expect("ok")
            .contains("DISPLAY = ./other.py"));
    }
}
