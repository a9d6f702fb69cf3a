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
    /// `@SPINDLE@`: the process's `--spindle` (`scenario` or `program`).
    pub spindle: super::process::SpindleMode,
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
    /// `--capture`: `capture.hal` (LinuxCNC's `halsampler` on the joints' positions) is
    /// written and loaded after `acc.hal`; `@CAPTURE@` = `halsampler.txt`.
    pub capture: bool,
}

/// The capture's file in the run's folder (`acc linuxcnc --capture`).
pub const CAPTURE_FILE: &str = "halsampler.txt";

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
        .replace("@SPINDLE@", fill.spindle.as_arg())
        .replace("@CONFIG@", &p(&fill.config))
        .replace("@RUN_ARGS@", &fill.run_args)
        .replace("@WATCHDOG_S@", &format!("{}", fill.watchdog_s))
        .replace("@RUN_LOG@", &p(&fill.dir.join("run.csv")))
        .replace("@MACHINE_LOG@", &p(&fill.dir.join("machine.csv")))
        .replace("@CAPTURE@", &p(&fill.dir.join(CAPTURE_FILE)))
}

/// The run's `acc.ini`: the template filled in, with the `--ini` values set.
pub fn ini_text(fill: &Fill) -> anyhow::Result<String> {
    let mut text = fill_in(&template("acc.ini")?, fill);
    if fill.capture {
        text = text.replacen(
            "HALFILE = acc.hal\n",
            "HALFILE = acc.hal\nHALFILE = capture.hal\n",
            1,
        );
    }
    super::ini::apply(&text, &fill.ini)
}

/// `values` checked against the shipped template (before anything is written or run).
pub fn check_ini(values: &[super::ini::IniValue]) -> anyhow::Result<()> {
    super::ini::apply(&template("acc.ini")?, values).map(|_| ())
}

/// Writes `acc.ini`, `acc.hal`, `ui.py` (executable) and `tool.tbl` into `fill.dir`; the
/// INI's path. The tool table is the `tools` file if given, else the template's with every
/// tool the program changes to ([`table_for_program`]).
pub fn write_files(
    fill: &Fill,
    tools: Option<&Path>,
    scenario_diameter_mm: f64,
) -> anyhow::Result<PathBuf> {
    let dir = &fill.dir;
    let write = |name: &str, text: String| -> anyhow::Result<PathBuf> {
        let path = dir.join(name);
        std::fs::write(&path, text)
            .with_context(|| format!("--out {}: cannot write {name}", dir.display()))?;
        Ok(path)
    };
    let ini = write("acc.ini", ini_text(fill)?)?;
    write("acc.hal", fill_in(&template("acc.hal")?, fill))?;
    if fill.capture {
        write("capture.hal", fill_in(&template("capture.hal")?, fill))?;
    }
    let ui = write("ui.py", template("ui.py")?)?;
    {
        use std::os::unix::fs::PermissionsExt as _;
        std::fs::set_permissions(&ui, std::fs::Permissions::from_mode(0o755))
            .with_context(|| format!("{}: cannot make it executable", ui.display()))?;
    }
    let table = match tools {
        Some(t) => std::fs::read_to_string(t)
            .with_context(|| format!("--tools {}: cannot read", t.display()))?,
        None => table_for_program(&template("tool.tbl")?, &fill.program, scenario_diameter_mm),
    };
    write("tool.tbl", table)?;
    Ok(ini)
}

/// The tool numbers a program changes to (`T… M6`, tool 0 left out), in order of first use;
/// empty if acc's interpreter does not read the program (LinuxCNC then reports its error).
fn program_tools(program: &Path) -> Vec<u32> {
    let setup = acc_nc::Setup {
        tools: acc_sim::program::scenario_tool_table(16.0),
        ..acc_nc::Setup::default()
    };
    let Ok(p) = acc_nc::interpret_file(program, &setup) else {
        return Vec::new();
    };
    let mut tools = Vec::new();
    for call in &p.calls {
        if let acc_nc::Canon::ToolChange { tool } = call.call {
            if tool > 0 && !tools.contains(&tool) {
                tools.push(tool);
            }
        }
    }
    tools
}

/// The tool table without `--tools`: `template` with a line for every tool of `program`
/// that it lacks, of the scenario's diameter and length 0, so that LinuxCNC changes to it
/// (it refuses a `T… M6` whose tool is not in its table) and the process cuts with the
/// scenario's tool, as `acc sim --program` does without `--tools`.
pub fn table_for_program(template: &str, program: &Path, diameter_mm: f64) -> String {
    let listed: Vec<u32> = template
        .lines()
        .filter_map(|l| l.split_whitespace().next()?.strip_prefix('T')?.parse().ok())
        .collect();
    let mut table = template.to_string();
    if !table.ends_with('\n') {
        table.push('\n');
    }
    for tool in program_tools(program) {
        if !listed.contains(&tool) {
            table.push_str(&format!(
                "T{tool} P{tool} D{diameter_mm:.6} Z0.000000 ;the scenario's tool (acc linuxcnc without --tools)\n"
            ));
        }
    }
    table
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
            spindle: super::super::process::SpindleMode::Program,
            config: "/c/acc.toml".into(),
            run_args: "--plan /p/plan.csv".into(),
            watchdog_s: 0.2,
            dir: "/run".into(),
            ini: vec![super::super::ini::parse("AXIS_Y.MAX_ACCELERATION=40").expect("ini")],
            capture: true,
        };
        for name in ["acc.ini", "acc.hal", "capture.hal"] {
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
        assert!(hal.contains("--stock-box=0,0,-5,10,10,0 --spindle program --log /run/machine.csv"));
        let ini = fill_in(&template("acc.ini").expect("ini"), &fill);
        assert!(ini.contains("OPEN_FILE = /p/part.ngc") && ini.contains("M52 P1"));
        // `--ini` reaches the shipped template's axis and joint.
        let ini = ini_text(&fill).expect("ini");
        assert_eq!(ini.matches("MAX_ACCELERATION = 40").count(), 2, "{ini}");
        assert!(
            ini.contains("HALFILE = acc.hal\nHALFILE = capture.hal\n"),
            "{ini}"
        );
        let capture = fill_in(&template("capture.hal").expect("capture"), &fill);
        assert!(
            capture.contains("halsampler -c 0 -t /run/halsampler.txt"),
            "{capture}"
        );
        let plain = ini_text(&Fill {
            capture: false,
            ..fill
        })
        .expect("ini");
        assert!(!plain.contains("capture.hal"), "{plain}");
    }

    #[test]
    fn the_table_gains_the_programs_tools_it_lacks() {
        let dir = tempfile::tempdir().expect("temp dir");
        let program = dir.path().join("p.ngc");
        std::fs::write(
            &program,
            "G21 G90\nT2 M6\nG1 X1 F100\nT13 M6\nT2 M6\nT0 M6\nM2\n",
        )
        .expect("program");
        let template = "T1 P1 D16.000000 Z0.000000 ;a\nT2 P2 D10.000000 Z0.000000 ;b\n";
        let table = table_for_program(template, &program, 16.0);
        assert!(table.starts_with(template), "{table}");
        let added: Vec<&str> = table.lines().skip(2).collect();
        assert_eq!(added.len(), 1, "{table}");
        assert!(
            added[0].starts_with("T13 P13 D16.000000 Z0.000000 ;"),
            "{table}"
        );
        // LinuxCNC's own table reader accepts the lines (mm).
        let t = acc_nc::ToolTable::parse_tbl("tool.tbl", &table, acc_nc::Units::Mm).expect("tbl");
        assert_eq!(t.get(13).map(|e| e.diameter_mm), Some(16.0));
        // A program acc cannot read leaves the template as it is.
        std::fs::write(&program, "G1 X(\n").expect("program");
        assert_eq!(table_for_program(template, &program, 16.0), template);
    }
}
