//! The information model, after OPC 40501-1 (Machine Tools) and 40502 (CNC Systems): the node
//! tree under `Objects`, its string node ids, and the values of one [`RunRecord`].
//!
//! async-opcua ships the core namespace only, not the companion specifications' types, so the
//! objects are `BaseObjectType` instances (and `FeedOverride` an `AnalogUnitRangeType`
//! variable) with the companion's browse names, all in the namespace [`NAMESPACE`]
//! (docs/opcua.md "Information model"):
//!
//! ```text
//! Objects
//! ├─ MachineTool                      ns;s=MachineTool
//! │  └─ Monitoring                    ns;s=MachineTool/Monitoring
//! │     ├─ Channel1                   …/Monitoring/Channel1
//! │     │  ├─ FeedOverride   Double % …/Channel1/FeedOverride     EURange 0..150, EngineeringUnits %
//! │     │  └─ FeedHold       Boolean
//! │     └─ Spindle                    …/Monitoring/Spindle
//! │        ├─ Override       Double % (not read from the PMC: BadNoData)
//! │        ├─ IsRotating     Boolean
//! │        ├─ ActSpeed       Double rpm
//! │        └─ ActPower       Double W (the spindle drive's power)
//! └─ Acc                              ns;s=Acc                    (events, also on Server)
//!    ├─ Period UInt64, MachineTime s, Force N, ForceRef N, KcHat N/(mm/min), PathFeed mm/min,
//!    ├─ OverrideCommanded %, OverrideOperator %, State, Tool, Program, Block,
//!    └─ AlarmBits (bits as the run log), Availability
//! ```

use acc_runtime::RunRecord;
use opcua::nodes::{NodeType, ObjectBuilder, VariableBuilder};
use opcua::server::address_space::{AccessLevel, AddressSpace, EventNotifier};
use opcua::types::{
    DataTypeId, DataValue, DateTime, EUInformation, NodeId, ObjectId, ObjectTypeId, QualifiedName,
    Range, StatusCode, VariableTypeId, Variant,
};

/// Our namespace URI (index 2 on this server: 0 is OPC UA's, 1 the server's own).
pub const NAMESPACE: &str = "urn:acc:opcua";

/// Upper end of the feed override's EURange, % (the PMC's 0–150 % override).
pub const FEED_OVERRIDE_MAX_PCT: f64 = 150.0;

/// UNECE code of "percent" (`P1`) as the OPC UA unitId (Part 8, EUInformation).
const UNIT_PERCENT: i32 = 20529;

/// Type of a variable's value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Double,
    Bool,
    UInt16,
    UInt64,
    Text,
    Byte,
}

impl Kind {
    fn data_type(self) -> DataTypeId {
        match self {
            Kind::Double => DataTypeId::Double,
            Kind::Bool => DataTypeId::Boolean,
            Kind::UInt16 => DataTypeId::UInt16,
            Kind::UInt64 => DataTypeId::UInt64,
            Kind::Text => DataTypeId::String,
            Kind::Byte => DataTypeId::Byte,
        }
    }
}

/// One variable of the model: parent path, browse name, type, unit (documentation), and how
/// to take its value from a record (`None`: unknown, sent as `BadNoData`).
struct Var {
    parent: &'static str,
    name: &'static str,
    kind: Kind,
    doc: &'static str,
    value: fn(&RunRecord) -> Option<Variant>,
}

fn f(v: Option<f64>) -> Option<Variant> {
    v.filter(|x| x.is_finite()).map(Variant::from)
}

fn pct(v: Option<u16>) -> Option<Variant> {
    v.map(|x| Variant::from(f64::from(x)))
}

/// Every variable, in the order of the update.
const VARS: [Var; 20] = [
    Var {
        parent: "MachineTool/Monitoring/Channel1",
        name: "FeedOverride",
        kind: Kind::Double,
        doc: "Feed override in force on the PMC, % (AnalogUnitRange 0..150)",
        value: |r| pct(r.override_applied_pct),
    },
    Var {
        parent: "MachineTool/Monitoring/Channel1",
        name: "FeedHold",
        kind: Kind::Bool,
        doc: "Feed hold requested by ACC",
        value: |r| Some(r.feed_hold.into()),
    },
    Var {
        parent: "MachineTool/Monitoring/Spindle",
        name: "Override",
        kind: Kind::Double,
        doc: "Spindle override, % (not on the board's register map: BadNoData)",
        value: |_| None,
    },
    Var {
        parent: "MachineTool/Monitoring/Spindle",
        name: "IsRotating",
        kind: Kind::Bool,
        doc: "Spindle turning (speed above 1 rpm)",
        value: |r| r.spindle_rpm.filter(|x| x.is_finite()).map(|x| (x.abs() > 1.0).into()),
    },
    Var {
        parent: "MachineTool/Monitoring/Spindle",
        name: "ActSpeed",
        kind: Kind::Double,
        doc: "Spindle speed, rpm",
        value: |r| f(r.spindle_rpm),
    },
    Var {
        parent: "MachineTool/Monitoring/Spindle",
        name: "ActPower",
        kind: Kind::Double,
        doc: "Spindle drive power, W",
        value: |r| f(r.power_w),
    },
    Var {
        parent: "Acc",
        name: "Period",
        kind: Kind::UInt64,
        doc: "Control period index (the run log's `period`)",
        value: |r| Some(r.period.into()),
    },
    Var {
        parent: "Acc",
        name: "MachineTime",
        kind: Kind::Double,
        doc: "Machine time since the run began, s",
        value: |r| f(Some(r.t_s)),
    },
    Var {
        parent: "Acc",
        name: "Force",
        kind: Kind::Double,
        doc: "Estimated cutting force, N",
        value: |r| f(r.force_n),
    },
    Var {
        parent: "Acc",
        name: "ForceRef",
        kind: Kind::Double,
        doc: "Force reference Fr, N",
        value: |r| f(r.force_ref_n),
    },
    Var {
        parent: "Acc",
        name: "KcHat",
        kind: Kind::Double,
        doc: "Estimated process gain Kc_hat, N/(mm/min)",
        value: |r| f(r.kc_hat),
    },
    Var {
        parent: "Acc",
        name: "PathFeed",
        kind: Kind::Double,
        doc: "Actual path feed, mm/min",
        value: |r| f(r.feed_mm_min),
    },
    Var {
        parent: "Acc",
        name: "OverrideCommanded",
        kind: Kind::Double,
        doc: "Override ACC commanded, %",
        value: |r| pct(r.override_cmd_pct),
    },
    Var {
        parent: "Acc",
        name: "OverrideOperator",
        kind: Kind::Double,
        doc: "Operator's override knob, %",
        value: |r| pct(r.override_operator_pct),
    },
    Var {
        parent: "Acc",
        name: "State",
        kind: Kind::Text,
        doc: "ACC policy state (`active`, `idle`, latched reason)",
        value: |r| Some(r.state.clone().into()),
    },
    Var {
        parent: "Acc",
        name: "Tool",
        kind: Kind::UInt16,
        doc: "Tool number",
        value: |r| r.tool.map(Variant::from),
    },
    Var {
        parent: "Acc",
        name: "Program",
        kind: Kind::UInt16,
        doc: "Program number",
        value: |r| r.program.map(Variant::from),
    },
    Var {
        parent: "Acc",
        name: "Block",
        kind: Kind::UInt16,
        doc: "Block (sequence) number",
        value: |r| r.block.map(Variant::from),
    },
    Var {
        parent: "Acc",
        name: "AlarmBits",
        kind: Kind::Byte,
        doc: "Alarm bits as the run log's `alarms` (bit 0 link, 1 power, 2 watchdog, 3 board reset, 4 overload)",
        value: |r| Some(r.alarms.into()),
    },
    Var {
        parent: "Acc",
        name: "Availability",
        kind: Kind::Text,
        doc: "`AVAILABLE` unless the period's board read failed",
        value: |r| {
            Some(
                if crate::items::available(r) {
                    "AVAILABLE"
                } else {
                    "UNAVAILABLE"
                }
                .into(),
            )
        },
    },
];

/// The objects: (path, browse name, parent path or `""` for `Objects`, emits events).
const OBJECTS: [(&str, &str, &str, bool); 5] = [
    ("MachineTool", "MachineTool", "", false),
    ("MachineTool/Monitoring", "Monitoring", "MachineTool", false),
    (
        "MachineTool/Monitoring/Channel1",
        "Channel1",
        "MachineTool/Monitoring",
        false,
    ),
    (
        "MachineTool/Monitoring/Spindle",
        "Spindle",
        "MachineTool/Monitoring",
        false,
    ),
    ("Acc", "Acc", "", true),
];

/// The node ids of the model in namespace `ns`.
#[derive(Debug, Clone)]
pub struct Model {
    ns: u16,
    vars: Vec<NodeId>,
}

impl Model {
    /// Node id of `path` (e.g. `Acc/Force`).
    pub fn id(ns: u16, path: &str) -> NodeId {
        NodeId::new(ns, path.to_string())
    }

    /// The source node of the events (`Acc`): the server also notifies them on the standard
    /// `Server` object, where most clients subscribe.
    pub fn event_source(&self) -> NodeId {
        Self::id(self.ns, "Acc")
    }

    /// Build the tree into `space` (namespace index `ns`).
    pub fn build(space: &mut AddressSpace, ns: u16) -> Self {
        for (path, name, parent, events) in OBJECTS {
            let parent_id: NodeId = if parent.is_empty() {
                ObjectId::ObjectsFolder.into()
            } else {
                Self::id(ns, parent)
            };
            let mut b = ObjectBuilder::new(&Self::id(ns, path), QualifiedName::new(ns, name), name)
                .has_type_definition(ObjectTypeId::BaseObjectType);
            b = if parent.is_empty() {
                b.organized_by(parent_id)
            } else {
                b.component_of(parent_id)
            };
            if events {
                b = b.event_notifier(EventNotifier::SUBSCRIBE_TO_EVENTS);
            }
            b.insert(space);
        }
        let mut vars = Vec::with_capacity(VARS.len());
        for v in &VARS {
            let path = format!("{}/{}", v.parent, v.name);
            let id = Self::id(ns, &path);
            let analog = v.name == "FeedOverride";
            VariableBuilder::new(&id, QualifiedName::new(ns, v.name), v.name)
                .description(v.doc)
                .data_type(v.kind.data_type())
                .access_level(AccessLevel::CURRENT_READ)
                .user_access_level(AccessLevel::CURRENT_READ)
                .minimum_sampling_interval(0.0)
                .has_type_definition(if analog {
                    VariableTypeId::AnalogUnitRangeType
                } else {
                    VariableTypeId::BaseDataVariableType
                })
                .component_of(Self::id(ns, v.parent))
                .insert(space);
            // Before the first period: no value yet.
            if let Some(NodeType::Variable(var)) = space.find_mut(&id) {
                var.set_data_value(DataValue {
                    value: Some(Variant::Empty),
                    status: Some(StatusCode::BadWaitingForInitialData),
                    ..DataValue::null()
                });
            }
            if analog {
                Self::analog_properties(space, ns, &path, &id);
            }
            vars.push(id);
        }
        Self { ns, vars }
    }

    /// `EURange` (0..150) and `EngineeringUnits` (%) of the feed override (Part 8).
    fn analog_properties(space: &mut AddressSpace, ns: u16, path: &str, of: &NodeId) {
        let range = Range {
            low: 0.0,
            high: FEED_OVERRIDE_MAX_PCT,
        };
        let unit = EUInformation {
            namespace_uri: "http://www.opcfoundation.org/UA/units/un/cefact".into(),
            unit_id: UNIT_PERCENT,
            display_name: "%".into(),
            description: "percent".into(),
        };
        for (name, dt, value) in [
            ("EURange", DataTypeId::Range, Variant::from(range)),
            (
                "EngineeringUnits",
                DataTypeId::EUInformation,
                Variant::from(unit),
            ),
        ] {
            VariableBuilder::new(
                &Self::id(ns, &format!("{path}/{name}")),
                QualifiedName::new(0, name),
                name,
            )
            .data_type(dt)
            .value(value)
            .access_level(AccessLevel::CURRENT_READ)
            .user_access_level(AccessLevel::CURRENT_READ)
            .has_type_definition(VariableTypeId::PropertyType)
            .property_of(of.clone())
            .insert(space);
        }
    }

    /// The values of record `r`, all with source timestamp `at` (unknown: `BadNoData`).
    pub fn values<'a>(
        &'a self,
        r: &'a RunRecord,
        at: DateTime,
    ) -> impl Iterator<Item = (&'a NodeId, DataValue)> + 'a {
        self.vars.iter().zip(VARS.iter()).map(move |(id, v)| {
            let dv = match (v.value)(r) {
                Some(x) => DataValue {
                    value: Some(x),
                    status: Some(StatusCode::Good),
                    source_timestamp: Some(at),
                    server_timestamp: Some(at),
                    ..DataValue::null()
                },
                None => DataValue {
                    value: Some(Variant::Empty),
                    status: Some(StatusCode::BadNoData),
                    source_timestamp: Some(at),
                    server_timestamp: Some(at),
                    ..DataValue::null()
                },
            };
            (id, dv)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_maps_to_the_variables_and_unknown_is_bad_no_data() {
        let m = Model {
            ns: 2,
            vars: VARS
                .iter()
                .map(|v| Model::id(2, &format!("{}/{}", v.parent, v.name)))
                .collect(),
        };
        let r = RunRecord {
            period: 7,
            override_applied_pct: Some(85),
            force_n: Some(812.5),
            spindle_rpm: Some(6000.0),
            ..RunRecord::default()
        };
        let got: Vec<(String, DataValue)> = m
            .values(&r, DateTime::now())
            .map(|(id, dv)| (id.to_string(), dv))
            .collect();
        let get = |p: &str| {
            got.iter()
                .find(|(id, _)| id.ends_with(p))
                .map(|(_, dv)| dv.clone())
                .expect(p)
        };
        assert_eq!(
            get("Channel1/FeedOverride").value,
            Some(Variant::Double(85.0))
        );
        assert_eq!(get("Acc/Force").value, Some(Variant::Double(812.5)));
        assert_eq!(get("Acc/Period").value, Some(Variant::UInt64(7)));
        assert_eq!(
            get("Spindle/IsRotating").value,
            Some(Variant::Boolean(true))
        );
        assert_eq!(get("Acc/KcHat").status, Some(StatusCode::BadNoData));
        assert_eq!(Model::id(2, "Acc/Force").to_string(), "ns=2;s=Acc/Force");
    }
}
