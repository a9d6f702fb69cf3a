//! The files of one `acc linuxcnc` run: the templates of `configs/linuxcnc/` (found as
//! every shipped config is, [`crate::configs::find`]) written into the run's folder with
//! their `@KEY@` placeholders filled in.

use std::path::{Path, PathBuf};

use anyhow::Context as _;

/// What the templates' placeholders become (absolute paths, so that LinuxCNC's processes
/// find them from any working directory).
#[derive(Debug, Clone)]
pub struct Fill {
    /// `@ACC@`: the `acc` binary.
    pub acc: PathBuf,
    /// `@PROGRAM@`: the NC program.
    pub program: PathBuf,
    /// `@SCENARIO@`: the process's scenario.
    pub scenario: PathBuf,
    /// `@STOCK@`: the process's stock options (`--stock-box=…` or `--stock FILE`, `--cell`,
    /// `--tools`).
    pub stock_args: String,
    /// `@CONFIG@`: acc's run config.
    pub config: PathBuf,
    /// `@RUN_ARGS@`: more options of `acc run` (`--plan …`).
    pub run_args: String,
    /// `@WATCHDOG_S@`: the watchdog's timeout, s.
    pub watchdog_s: f64,
    /// The run's folder: `@RUN_LOG@` = `run.csv`, `@MACHINE_LOG@` = `machine.csv` in it.
    pub dir: PathBuf,
    /// `--ini` values written into `acc.ini` ([`super::ini::apply`]).
    pub ini: Vec<super::ini::IniValue>,
}

/// The shipped template `name` of `configs/linuxcnc/`, read.
fn template(name: &str) -> anyhow::Result<String> {
    let path = crate::configs::find("linuxcnc", &format!("configs/linuxcnc/{name}"));
    std::fs::read_to_string(&path)
        .with_context(|| format!("the template {}: cannot read", path.display()))
}

/// `text` with every `@KEY@` of `fill` replaced.
fn fill_in(text: &str, fill: &Fill) -> String {
    let p = |p: &Path| p.display().to_string();
    text.replace("@ACC@", &p(&fill.acc))
        .replace("@PROGRAM@", &p(&fill.program))
        .replace("@SCENARIO@", &p(&fill.scenario))
        .replace("@STOCK@", &fill.stock_args)
        .replace("@CONFIG@", &p(&fill.config))
        .replace("@RUN_ARGS@", &fill.run_args)
        .replace("@WATCHDOG_S@", &format!("{}", fill.watchdog_s))
        .replace("@RUN_LOG@", &p(&fill.dir.join("run.csv")))
        .replace("@MACHINE_LOG@", &p(&fill.dir.join("machine.csv")))
}

/// The run's `acc.ini`: the template filled in, with the `--ini` values set.
pub fn ini_text(fill: &Fill) -> anyhow::Result<String> {
    super::ini::apply(&fill_in(&template("acc.ini")?, fill), &fill.ini)
}

/// `values` checked against the shipped template (before anything is written or run).
pub fn check_ini(values: &[super::ini::IniValue]) -> anyhow::Result<()> {
    super::ini::apply(&template("acc.ini")?, values).map(|_| ())
}

/// Writes `acc.ini`, `acc.hal`, `ui.py` (executable) and `tool.tbl` (the `tools` file if
/// given, else the template's) into `fill.dir`; the INI's path.
pub fn write_files(fill: &Fill, tools: Option<&Path>) -> anyhow::Result<PathBuf> {
    let dir = &fill.dir;
    let write = |name: &str, text: String| -> anyhow::Result<PathBuf> {
        let path = dir.join(name);
        std::fs::write(&path, text)
            .with_context(|| format!("--out {}: cannot write {name}", dir.display()))?;
        Ok(path)
    };
    let ini = write("acc.ini", ini_text(fill)?)?;
    write("acc.hal", fill_in(&template("acc.hal")?, fill))?;
    let ui = write("ui.py", template("ui.py")?)?;
    {
        use std::os::unix::fs::PermissionsExt as _;
        std::fs::set_permissions(&ui, std::fs::Permissions::from_mode(0o755))
            .with_context(|| format!("{}: cannot make it executable", ui.display()))?;
    }
    let table = match tools {
        Some(t) => std::fs::read_to_string(t)
            .with_context(|| format!("--tools {}: cannot read", t.display()))?,
        None => template("tool.tbl")?,
    };
    write("tool.tbl", table)?;
    Ok(ini)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_placeholder_of_the_shipped_templates_is_filled() {
        let fill = Fill {
            acc: "/usr/bin/acc".into(),
            program: "/p/part.ngc".into(),
            scenario: "/s/sc.toml".into(),
            stock_args: "--stock-box=0,0,-5,10,10,0".into(),
            config: "/c/acc.toml".into(),
            run_args: "--plan /p/plan.csv".into(),
            watchdog_s: 0.2,
            dir: "/run".into(),
            ini: vec![super::super::ini::parse("AXIS_Y.MAX_ACCELERATION=40").expect("ini")],
        };
        for name in ["acc.ini", "acc.hal"] {
            let text = fill_in(&template(name).expect("template"), &fill);
            let left: Vec<&str> = text
                .lines()
                .filter(|l| !l.trim_start().starts_with('#') && l.contains('@'))
                .collect();
            assert!(left.is_empty(), "{name}: {left:?}");
        }
        let hal = fill_in(&template("acc.hal").expect("hal"), &fill);
        assert!(hal.contains(
            "loadusr -Wn acc /usr/bin/acc run --hal acc --config /c/acc.toml --log /run/run.csv --plan /p/plan.csv"
        ));
        assert!(hal.contains("setp watchdog.timeout-0 0.2"));
        let ini = fill_in(&template("acc.ini").expect("ini"), &fill);
        assert!(ini.contains("OPEN_FILE = /p/part.ngc") && ini.contains("M52 P1"));
        // `--ini` reaches the shipped template's axis and joint.
        let ini = ini_text(&fill).expect("ini");
        assert_eq!(ini.matches("MAX_ACCELERATION = 40").count(), 2, "{ini}");
    }
}
