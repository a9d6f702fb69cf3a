//! `acc linuxcnc-process --scenario S --stock-box … --log machine.csv`: the simulated
//! cutting process as a userspace HAL component (`acc-process` by default). Every
//! `--period-ms` it reads LinuxCNC's axis positions, feed, spindle speed and tool number,
//! cuts the stock along that path ([`super::cut::LiveCut`]), puts the spindle's
//! electrical power (the mean over the scenario's control period, as a power meter or the
//! board reports it) on `acc-process.spindle-power` and writes one machine-log row.
//!
//! Pins (netted in `configs/linuxcnc/acc.hal`):
//!
//! | pin | type | what | net it to |
//! | --- | --- | --- | --- |
//! | `acc-process.position-x/-y/-z` | float in, mm | tool tip | `axis.L.pos-cmd` / `joint.N.pos-fb` |
//! | `acc-process.feed` | float in, mm/s | path speed | `motion.current-vel` |
//! | `acc-process.spindle-speed` | float in, rpm | LinuxCNC's commanded spindle | `spindle.0.speed-out` |
//! | `acc-process.tool-number` | s32 in | tool | `iocontrol.0.tool-number` |
//! | `acc-process.adaptive-feed`, `heartbeat`, `feed-inhibit` | float / bit / bit in | logged only | `acc.adaptive-feed`, `acc.heartbeat-bit`, `motion.feed-inhibit` |
//! | `acc-process.feed-override` | float in | logged only | `halui.feed-override.value` |
//! | `acc-process.fault` | bit in | logged only: set by `ui.py` at a fault's moment | (`setp`) |
//! | `acc-process.spindle-power` | float out, W | electrical power, mean over T | `acc.spindle-power` |
//! | `acc-process.sample-seq` | s32 out | advances with every power sample: stands still when the process stops | `acc.sample-seq` |
//! | `acc-process.spindle-rpm` | float out, rpm | the simulated spindle's speed (`--spindle`), as a VFD's speed feedback | `acc.spindle-speed` |
//! | `acc-process.force` | float out, N | true force | (a scope) |
//! | `acc-process.radial-depth`, `axial-depth` | float out, mm | engagement | (a scope) |

use std::collections::VecDeque;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::Duration;

use acc_hal::HalComponent;
use acc_runtime::{Clock as _, SystemClock};
use anyhow::Context as _;

use super::cut::LiveCut;

/// Arguments of `acc linuxcnc-process`.
#[derive(Debug, Clone, clap::Args)]
pub struct ProcessArgs {
    /// Scenario (machine, tool, process), e.g. `configs/scenarios/paper_case3.toml`.
    #[arg(long)]
    pub scenario: PathBuf,
    /// The stock, and the tool table with the diameters of the tool numbers (without it,
    /// the scenario's tool).
    #[command(flatten)]
    pub stock: crate::cmd_sim_program::StockArgs,
    /// Machine log (CSV, one row per period): time, position, feed, speed, tool,
    /// engagement, true force, power.
    #[arg(long, default_value = "machine.csv")]
    pub log: PathBuf,
    /// The HAL component's name (pins `<name>.*`).
    #[arg(long, default_value = "acc-process")]
    pub name: String,
    /// The process's period, ms (1 ..= 10): how often it follows LinuxCNC's path.
    #[arg(long, default_value_t = 2)]
    pub period_ms: u64,
    /// The simulated spindle's speed while LinuxCNC's spindle turns: `scenario` (the
    /// scenario's machine, as `acc sim --program` and `acc plan` model it) or `program`
    /// (LinuxCNC's commanded speed, the program's S word).
    #[arg(long, value_enum, default_value_t = SpindleMode::Scenario)]
    pub spindle: SpindleMode,
}

/// Where the simulated spindle's speed comes from ([`ProcessArgs::spindle`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SpindleMode {
    /// The scenario's spindle speed (`[spindle] rpm` of its machine), in LinuxCNC's
    /// direction, whenever LinuxCNC's spindle turns; 0 when it stands.
    Scenario,
    /// LinuxCNC's commanded speed (`spindle.0.speed-out`).
    Program,
}

impl SpindleMode {
    /// The option's value on a command line.
    pub fn as_arg(self) -> &'static str {
        match self {
            SpindleMode::Scenario => "scenario",
            SpindleMode::Program => "program",
        }
    }

    /// The simulated spindle's speed, rpm, for LinuxCNC's commanded `commanded_rpm` on a
    /// machine whose spindle turns at `scenario_rpm`.
    pub fn rpm(self, commanded_rpm: f64, scenario_rpm: f64) -> f64 {
        match self {
            SpindleMode::Program => commanded_rpm,
            SpindleMode::Scenario if commanded_rpm == 0.0 => 0.0,
            SpindleMode::Scenario => scenario_rpm.abs() * commanded_rpm.signum(),
        }
    }
}

/// The machine log's header.
pub const MACHINE_LOG_HEADER: &str = "t_s,x_mm,y_mm,z_mm,feed_mm_min,spindle_rpm,tool,radial_mm,axial_mm,force_n,power_w,power_mean_w,adaptive_feed,heartbeat,feed_inhibit,feed_override,fault";

/// The checked inputs of a process run: the scenario, the stock and the tool table.
pub struct ProcessSetup {
    /// The scenario.
    pub scenario: acc_sim::Scenario,
    /// The cutting process on its stock.
    pub cut: LiveCut,
}

/// Loads and checks `--scenario`, the stock and `--tools`, and `--period-ms`: every error
/// names its flag and the allowed range.
pub fn setup(args: &ProcessArgs) -> anyhow::Result<ProcessSetup> {
    if !(1..=10).contains(&args.period_ms) {
        anyhow::bail!("--period-ms {}: allowed 1 ..= 10", args.period_ms);
    }
    let scenario = acc_sim::Scenario::load(&args.scenario)
        .with_context(|| format!("--scenario {}", args.scenario.display()))?;
    let stock = args
        .stock
        .source()?
        .build()
        .map_err(|e| anyhow::anyhow!("the stock: {e}"))?;
    let table = match &args.stock.tools {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("--tools {}: cannot read", p.display()))?;
            let t =
                acc_nc::ToolTable::parse_tbl(&p.display().to_string(), &text, acc_nc::Units::Mm)
                    .map_err(|e| anyhow::anyhow!("--tools: {e}"))?;
            Some((t, p.clone()))
        }
        None => None,
    };
    let cut = LiveCut::new(&scenario, stock, table)?;
    Ok(ProcessSetup { scenario, cut })
}

/// `acc linuxcnc-process`.
pub fn run_cmd(args: &ProcessArgs) -> anyhow::Result<()> {
    let ProcessSetup { scenario, mut cut } = setup(args)?;
    if let Some(dir) = args.log.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("--log {}: cannot create its folder", args.log.display()))?;
    }
    let file = File::create(&args.log).with_context(|| {
        format!(
            "--log {}: cannot create the machine log",
            args.log.display()
        )
    })?;
    let mut log = BufWriter::new(file);
    writeln!(log, "{MACHINE_LOG_HEADER}")?;

    let hal = |e: acc_hal::HalError| anyhow::anyhow!("--name {}: HAL: {e}", args.name);
    let comp = HalComponent::new(&args.name).map_err(hal)?;
    let x = comp.float_in("position-x").map_err(hal)?;
    let y = comp.float_in("position-y").map_err(hal)?;
    let z = comp.float_in("position-z").map_err(hal)?;
    let feed = comp.float_in("feed").map_err(hal)?;
    let speed = comp.float_in("spindle-speed").map_err(hal)?;
    let tool = comp.s32_in("tool-number").map_err(hal)?;
    let adaptive = comp.float_in("adaptive-feed").map_err(hal)?;
    let heartbeat = comp.bit_in("heartbeat").map_err(hal)?;
    let inhibit = comp.bit_in("feed-inhibit").map_err(hal)?;
    let feed_override = comp.float_in("feed-override").map_err(hal)?;
    let fault = comp.bit_in("fault").map_err(hal)?;
    let mut seq_pin = comp.s32_out("sample-seq").map_err(hal)?;
    let mut power_pin = comp.float_out("spindle-power").map_err(hal)?;
    let mut rpm_pin = comp.float_out("spindle-rpm").map_err(hal)?;
    let mut force_pin = comp.float_out("force").map_err(hal)?;
    let mut radial_pin = comp.float_out("radial-depth").map_err(hal)?;
    let mut axial_pin = comp.float_out("axial-depth").map_err(hal)?;
    let stop = acc_runtime::shutdown::install_stop_flag().context("installing the stop handler")?;
    comp.ready().map_err(hal)?;

    let period = Duration::from_millis(args.period_ms);
    // The power's mean over the scenario's control period (the board's and a meter's).
    let window = ((scenario.controller.period_s / period.as_secs_f64()).round() as usize).max(1);
    let mut recent: VecDeque<f64> = VecDeque::with_capacity(window + 1);
    eprintln!(
        "linuxcnc-process: component `{}` ready: `{}` every {} ms, the spindle at {}, power the mean over {} ms; machine log {}",
        args.name,
        scenario.name,
        args.period_ms,
        match args.spindle {
            SpindleMode::Scenario => format!("the scenario's {} rpm", scenario.machine.spindle.rpm),
            SpindleMode::Program => "LinuxCNC's commanded speed".to_string(),
        },
        window as u64 * args.period_ms,
        args.log.display()
    );
    let clock = SystemClock::new();
    let mut next = clock.now();
    let mut rows: u64 = 0;
    let mut seq: i32 = 0;
    while !stop.load(Ordering::SeqCst) {
        next += period;
        let t_s = clock.now().as_secs_f64();
        let position = [x.get(), y.get(), z.get()];
        let feed_mm_min = 60.0 * feed.get().abs();
        let rpm = args.spindle.rpm(speed.get(), scenario.machine.spindle.rpm);
        let tool_no = u32::try_from(tool.get()).unwrap_or(0);
        let s = cut.sample(position, tool_no, feed_mm_min, rpm, t_s)?;
        let fault_now = fault.get();
        recent.push_back(s.power_w);
        if recent.len() > window {
            recent.pop_front();
        }
        let power_mean_w = recent.iter().sum::<f64>() / recent.len() as f64;
        power_pin.set(power_mean_w);
        seq = seq.wrapping_add(1);
        seq_pin.set(seq);
        rpm_pin.set(rpm);
        force_pin.set(s.force_n);
        radial_pin.set(s.radial_mm);
        axial_pin.set(s.axial_mm);
        writeln!(
            log,
            "{t_s:.4},{:.4},{:.4},{:.4},{feed_mm_min:.2},{rpm:.1},{tool_no},{:.4},{:.4},{:.2},{:.2},{power_mean_w:.2},{:.4},{},{},{:.3},{}",
            position[0],
            position[1],
            position[2],
            s.radial_mm,
            s.axial_mm,
            s.force_n,
            s.power_w,
            adaptive.get(),
            u8::from(heartbeat.get()),
            u8::from(inhibit.get()),
            feed_override.get(),
            u8::from(fault_now)
        )
        .with_context(|| format!("--log {}: write", args.log.display()))?;
        rows += 1;
        // A fault's rows at once: the fault may be this process's SIGKILL.
        if rows.is_multiple_of(50) || fault_now {
            log.flush()
                .with_context(|| format!("--log {}: write", args.log.display()))?;
        }
        let now = clock.now();
        if next > now {
            clock.sleep_until(next);
        } else {
            // Late (a loaded host): the next period starts now, none is run twice.
            next = now;
        }
    }
    log.flush()
        .with_context(|| format!("--log {}: write", args.log.display()))?;
    eprintln!("linuxcnc-process: {rows} rows in {}", args.log.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::SpindleMode;

    #[test]
    fn the_spindle_turns_at_the_scenarios_speed_in_linuxcncs_direction() {
        let m = SpindleMode::Scenario;
        assert_eq!(m.rpm(3400.0, 600.0), 600.0);
        assert_eq!(m.rpm(-3000.0, 600.0), -600.0);
        assert_eq!(m.rpm(0.0, 600.0), 0.0);
        assert_eq!(SpindleMode::Program.rpm(3400.0, 600.0), 3400.0);
        assert_eq!(SpindleMode::Program.rpm(0.0, 600.0), 0.0);
    }
}
