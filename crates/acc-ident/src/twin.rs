//! The honest twin: logs from the production path (`acc sim`'s closed loop, the same
//! [`acc_runtime::ControlLoop`] `acc run` drives) replayed by the simulator's own plant
//! ([`acc_sim::replay`]), and the model that describes a scenario's machine as the
//! discrepancy workflow sees it ([`model_for_scenario`]).

use std::path::Path;

use acc_sim::scenario::{MeasurementSpec, Scenario};

use crate::effects::Effects;
use crate::model::{Channel, FeedInput, Measurement, Model, PlantForceModel};
use crate::replay::{replay, Inputs, ReplayError};
use crate::runlog::RunLog;

/// The model of `scenario`'s machine, tool and wear, compared on `channel`, replayed by
/// the simulator's plant (`feed_input = "plant"`) with the scenario's force model and the
/// window and spindle motor of its measurement channel. On the power channel of a
/// spindle-power scenario the model's `no_load_power_w` is the motor's air-cut input
/// power at the spindle speed.
pub fn model_for_scenario(scenario: &Scenario, channel: Channel) -> Model {
    let mut machine = scenario.machine.clone();
    let mut tool = scenario.tool.clone();
    tool.wear = scenario.wear;
    let (force_window_s, power_window_s, motor) = match scenario.measurement {
        MeasurementSpec::Dynamometer { window_s, .. } => (window_s, 0.0, None),
        MeasurementSpec::SpindlePower(spec) => (spec.window_s, spec.window_s, Some(spec.motor)),
    };
    let motor = if channel == Channel::Power { motor } else { None };
    if let Some(m) = motor {
        if let Ok(cfg) = m.config() {
            machine.spindle.no_load_power_w = acc_sim::motor::Motor::new(cfg)
                .operating_point(machine.spindle.rpm, 0.0)
                .input_w;
        }
    }
    Model {
        name: format!("{} (twin of the scenario)", scenario.name),
        measurement: Measurement {
            channel,
            feed_input: FeedInput::Plant,
            force_window_s,
            force_model: match scenario.force_model {
                acc_sim::ForceModel::Mean => PlantForceModel::Mean,
                acc_sim::ForceModel::Tooth => PlantForceModel::Tooth,
            },
            spindle_motor: motor,
            power_window_s: if motor.is_some() { power_window_s } else { 0.0 },
        },
        machine,
        tool,
        effects: Effects::default(),
    }
}

/// Run `scenario` with its adaptive law through `acc sim`'s production loop and return the
/// run log as the workflow reads it.
pub fn simulate(scenario: &Scenario) -> Result<RunLog, String> {
    let mut law = scenario
        .build_law(acc_sim::LawKind::Ours)
        .map_err(|e| e.to_string())?;
    let res = acc_sim::run::<std::io::Sink>(scenario, law.as_mut(), None)
        .map_err(|e| e.to_string())?;
    crate::runlog::from_records(&res.rows, Path::new(&scenario.name)).map_err(|e| e.to_string())
}

/// Residual of the replay of `model` on `log` (measured − replayed), with the
/// engagement from `workpiece` when given (tool centre at `x0_mm` when the log began).
pub fn replay_residual(
    model: &Model,
    log: &RunLog,
    workpiece: Option<(&acc_sim::Workpiece, f64)>,
) -> Result<Vec<f64>, ReplayError> {
    let mut inp = Inputs::from_log(log, model)?;
    if let Some((wp, x0)) = workpiece {
        inp.use_workpiece(wp.clone(), x0);
    }
    let r = replay(model, &inp);
    Ok(inp
        .measured
        .iter()
        .zip(&r.predicted)
        .map(|(m, p)| m - p)
        .collect())
}
