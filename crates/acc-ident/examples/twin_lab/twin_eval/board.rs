//! `--path board`: the case's log is `acc run`'s, controlling `acc board-sim` over a pty —
//! two processes on their own clocks, the board's registers, `acc run`'s force estimate
//! from the power register — and the verdict is `acc discrepancy --workpiece`'s
//! `report.json` on it, the commands a user types.
//!
//! The hidden effect is written into the files board-sim reads: the case's machine and
//! tool as a model file (`[machine]`, `[tool]`), its workpiece, and a scenario naming
//! them with the case's wear, force model and seed (`write_case`). The logging-path
//! effects act on a logged column after the run, the same on either path, and are not
//! run here. One closed loop serves both channels: its log is kept in the case's
//! directory and analysed once per channel against `configs/models/paper_vmc_production.toml`
//! (the board's constant-efficiency power register and `acc run`'s estimator, no wear)
//! with the case's nominal workpiece.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use acc_ident::model::Channel;
use acc_ident::twin::{self, Hidden, Verdict};
use acc_ident::EffectKind;
use acc_sim::workpiece::SegmentKind;
use acc_sim::{Scenario, Workpiece};

/// The model the board's logs are analysed against.
const MODEL: &str = "configs/models/paper_vmc_production.toml";

/// `acc run`'s configuration for board-sim (case III, 4× time, 115 200 baud).
const RUN_CONFIG: &str = "configs/runtime/board_sim_fast.toml";

/// The controller preset of the evaluation's base scenario (`paper_case3.toml`).
const CONTROLLER: &str = "configs/presets/case3.toml";

/// Longest wall time a closed loop of `machine_s` at 4× may take before it counts as
/// stalled, s.
fn loop_timeout_s(machine_s: f64) -> f64 {
    machine_s / 4.0 * 3.0 + 60.0
}

/// `wp` as a workpiece file (`[[segment]]` tables): a segment whose depth changes is a
/// ramp; a leading stretch before x = 0 cannot be written (`Err`).
fn workpiece_toml(wp: &Workpiece) -> Result<String, String> {
    let mut s = format!(
        "name = {:?}\naxial_depth_mm = {}\n",
        wp.name, wp.axial_depth_mm
    );
    let first = wp.segments.first().map_or(0.0, |g| g.start_mm);
    if first < 0.0 {
        return Err(format!("the workpiece starts at {first} mm, before 0"));
    }
    if first > 0.0 {
        s += &format!("\n[[segment]]\nkind = \"air\"\nlength_mm = {first}\n");
    }
    for g in &wp.segments {
        let len = g.end_mm - g.start_mm;
        s += &match (g.kind, g.depth_start_mm == g.depth_end_mm) {
            (SegmentKind::Air, _) => format!("\n[[segment]]\nkind = \"air\"\nlength_mm = {len}\n"),
            (_, true) => format!(
                "\n[[segment]]\nkind = \"cut\"\nlength_mm = {len}\ndepth_mm = {}\nks_factor = {}\n",
                g.depth_start_mm, g.ks_factor
            ),
            (_, false) => format!(
                "\n[[segment]]\nkind = \"ramp\"\nlength_mm = {len}\nfrom_mm = {}\nto_mm = {}\nks_factor = {}\n",
                g.depth_start_mm, g.depth_end_mm, g.ks_factor
            ),
        };
    }
    Ok(s)
}

/// The case's files in `dir`: `model.toml` (the case's machine and tool), `workpiece.toml`
/// (the part board-sim cuts), `nominal_workpiece.toml` (the part the model knows) and
/// `scenario.toml`. Returns the scenario's and the nominal workpiece's paths.
fn write_case(
    root: &Path,
    dir: &Path,
    sc: &Scenario,
    nominal: &Workpiece,
) -> Result<(PathBuf, PathBuf), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut t = toml::Table::new();
    let val = |v: Result<toml::Value, toml::ser::Error>| v.map_err(|e| e.to_string());
    t.insert("machine".into(), val(toml::Value::try_from(&sc.machine))?);
    t.insert("tool".into(), val(toml::Value::try_from(&sc.tool))?);
    let model = toml::to_string(&t).map_err(|e| e.to_string())?;
    let wear = toml::to_string(&sc.wear).map_err(|e| e.to_string())?;
    let force_model = match sc.force_model {
        acc_sim::ForceModel::Mean => "mean",
        acc_sim::ForceModel::Tooth => "tooth",
    };
    let scenario = format!(
        "# Written by twin_eval --path board for one case.\nname = {:?}\nmodel = \"model.toml\"\nworkpiece = \"workpiece.toml\"\ncontroller = {:?}\nseed = {}\nprogrammed_feed_mm_min = {}\nforce_model = \"{force_model}\"\nmax_time_s = 3600.0\n\n[wear]\n{wear}",
        sc.name,
        root.join(CONTROLLER).to_string_lossy(),
        sc.seed,
        sc.programmed_feed_mm_min,
    );
    let files = [
        ("model.toml", model),
        ("workpiece.toml", workpiece_toml(&sc.workpiece)?),
        ("nominal_workpiece.toml", workpiece_toml(nominal)?),
        ("scenario.toml", scenario),
    ];
    for (name, text) in files {
        std::fs::write(dir.join(name), text).map_err(|e| format!("{name}: {e}"))?;
    }
    Ok((
        dir.join("scenario.toml"),
        dir.join("nominal_workpiece.toml"),
    ))
}

/// `acc board-sim` on `scenario` (4× time, 115 200 baud, machine time paced by the
/// controller) and `acc run` controlling it for `machine_s` of machine time, logging to
/// `dir/run.csv` (kept: a log already there is used again).
fn closed_loop(
    acc: &Path,
    root: &Path,
    dir: &Path,
    scenario: &Path,
    machine_s: f64,
) -> Result<PathBuf, String> {
    let log = dir.join("run.csv");
    let done = dir.join("run.done");
    if done.exists() && log.exists() {
        return Ok(log);
    }
    let file = |n: &str| std::fs::File::create(dir.join(n)).map_err(|e| format!("{n}: {e}"));
    let scen = scenario.to_string_lossy().into_owned();
    let mut board = Command::new(acc)
        .current_dir(root)
        .args([
            "board-sim",
            "--scenario",
            &scen,
            "--time-scale",
            "4",
            "--baud",
            "115200",
        ])
        .args(["--wait-for-controller", "--pace", "controller"])
        .stdout(Stdio::piped())
        .stderr(file("board-sim.err")?)
        .spawn()
        .map_err(|e| format!("acc board-sim: {e}"))?;
    let out = board.stdout.take().ok_or("board-sim's stdout")?;
    let mut lines = BufReader::new(out).lines();
    let pty = match lines.next() {
        Some(Ok(l)) if l.trim().starts_with("/dev/") => l.trim().to_string(),
        other => {
            let _ = board.kill();
            return Err(format!("board-sim printed no pty path: {other:?}"));
        }
    };
    // Keep board-sim's stdout drained.
    std::thread::spawn(move || lines.for_each(drop));
    let secs = format!("{machine_s}");
    let logs = log.to_string_lossy().into_owned();
    let mut run = Command::new(acc)
        .current_dir(root)
        .args([
            "run", "--config", RUN_CONFIG, "--port", &pty, "--log", &logs,
        ])
        .args(["--duration-s", &secs])
        .stdout(file("run.out")?)
        .stderr(file("run.err")?)
        .spawn()
        .map_err(|e| format!("acc run: {e}"))?;
    let t0 = Instant::now();
    let status = loop {
        match run.try_wait() {
            Ok(Some(s)) => break Some(s),
            Ok(None) if t0.elapsed().as_secs_f64() < loop_timeout_s(machine_s) => {
                std::thread::sleep(Duration::from_millis(200));
            }
            _ => break None,
        }
    };
    let _ = board.kill();
    let _ = board.wait();
    match status {
        Some(s) if s.success() => {
            std::fs::write(&done, "").map_err(|e| e.to_string())?;
            Ok(log)
        }
        Some(s) => Err(format!(
            "acc run exited with {s} (see {})",
            dir.join("run.err").display()
        )),
        None => {
            let _ = run.kill();
            Err(format!(
                "acc run did not end within {:.0} s",
                loop_timeout_s(machine_s)
            ))
        }
    }
}

/// `acc discrepancy --workpiece` on `log`, channel `channel`: the parsed `report.json`.
fn discrepancy(
    acc: &Path,
    root: &Path,
    log: &Path,
    wp: &Path,
    channel: Channel,
    out: &Path,
) -> Result<serde_json::Value, String> {
    let ch = match channel {
        Channel::Power => "power",
        Channel::Force => "force",
    };
    let (m, w, o) = (
        log.to_string_lossy(),
        wp.to_string_lossy(),
        out.to_string_lossy(),
    );
    let r = Command::new(acc)
        .current_dir(root)
        .args([
            "discrepancy",
            "--measured",
            &m,
            "--model",
            MODEL,
            "--workpiece",
            &w,
        ])
        .args(["--channel", ch, "--out", &o])
        .output()
        .map_err(|e| format!("acc discrepancy: {e}"))?;
    if !r.status.success() {
        return Err(format!(
            "acc discrepancy {ch}: {}",
            String::from_utf8_lossy(&r.stderr).trim()
        ));
    }
    let text = std::fs::read_to_string(out.join("report.json")).map_err(|e| e.to_string())?;
    serde_json::from_str(&text).map_err(|e| format!("report.json: {e}"))
}

/// Where and how the board path runs its cases.
pub struct BoardPath {
    /// The `acc` binary.
    pub acc: PathBuf,
    /// The evaluation's output directory (the cases under `board/`).
    pub out: PathBuf,
    /// Machine time of a closed loop, s.
    pub machine_s: f64,
}

impl BoardPath {
    /// The verdict of a board-sim case: the closed loop (run once per case, kept in
    /// `out/board/<label>-<workpiece>-<seed>/`), then `acc discrepancy` on `channel`; the
    /// case's effect-to-noise ratio is the one of the same case on `acc sim`'s log
    /// (`twin::effect_to_noise`: the board's log has no twin without the effect on the
    /// same clocks).
    pub fn run_case(
        &self,
        base: &Scenario,
        hidden: Hidden,
        channel: Channel,
        seed: u64,
        wp_name: &str,
    ) -> Result<Verdict, String> {
        let (acc, out, machine_s) = (&self.acc, &self.out, self.machine_s);
        let root = acc_sim::run::configs_dir()
            .parent()
            .map(Path::to_path_buf)
            .ok_or("the repository root")?;
        let label: String = hidden
            .label()
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '.' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        let dir = out.join("board").join(format!("{label}-{wp_name}-{seed}"));
        let (mut sc, _, nominal) = twin::hidden_case(base, hidden, channel);
        sc.seed = seed;
        let (scenario, nominal_wp) = write_case(&root, &dir, &sc, &nominal)?;
        let log = closed_loop(acc, &root, &dir, &scenario, machine_s)?;
        let report = discrepancy(
            acc,
            &root,
            &log,
            &nominal_wp,
            channel,
            &dir.join(format!("{channel:?}").to_lowercase()),
        )?;
        let strings = |v: &serde_json::Value| -> Vec<String> {
            v.as_array()
                .map(|a| {
                    a.iter()
                        .filter_map(|x| x.as_str().map(str::to_string))
                        .collect()
                })
                .unwrap_or_default()
        };
        let named: Vec<EffectKind> = strings(&report["accepted"])
            .iter()
            .filter_map(|n| EffectKind::from_name(n))
            .collect();
        let covered = match (hidden.library(), twin::truth_of(base, hidden)) {
            (Some(k), Some(v)) if named.contains(&k) => {
                let want = format!("{}.{}", k.name(), k.params()[0].key);
                report["updated_params"].as_array().and_then(|ps| {
                    ps.iter()
                        .find(|p| p["name"] == want.as_str())
                        .and_then(|p| {
                            Some(p["ci_low"].as_f64()? <= v && v <= p["ci_high"].as_f64()?)
                        })
                })
            }
            _ => None,
        };
        let withheld = report["withheld"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|w| w["effect"].as_str().map(str::to_string))
                    .collect()
            })
            .unwrap_or_default();
        let enr = twin::effect_to_noise(base, hidden, channel, seed)?;
        let enr_calibrated = twin::calibrated_effect_to_noise(base, hidden, channel, seed)?;
        Ok(Verdict {
            named,
            ambiguous: report["ambiguous"]
                .as_array()
                .is_some_and(|a| !a.is_empty()),
            unexplained: !report["unexplained"].is_null(),
            covered,
            withheld,
            conclusion: report["conclusion"]
                .as_str()
                .unwrap_or_default()
                .to_string(),
            explanation: strings(&report["explanation"]),
            enr,
            enr_calibrated,
        })
    }
}
