//! `acc-telemetry`: what the shop-floor network hears from `acc` — an MTConnect SHDR
//! adapter ([`shdr`]), an MQTT publisher ([`mqtt`]), the live view in the browser
//! ([`live`]) and an OPC UA server (`opcua`, docs/opcua.md; in the build with the `opcua`
//! feature), each fed by a subscriber of the
//! runtime's [`acc_runtime::tap::Tap`] (one [`acc_runtime::RunRecord`] per period), each on
//! its own threads: the control loop never waits on them. Items, lines, topics and the
//! config keys: `docs/telemetry.md`.
#![deny(missing_docs)]

pub mod items;
pub mod live;
pub mod mqtt;
pub mod mqtt_outbox;
#[cfg(feature = "opcua")]
pub mod opcua;
/// The OPC UA server of a build without the `opcua` feature (it refuses to start, naming
/// the feature). It is compiled, and linted, in every build.
#[doc(hidden)]
pub mod opcua_absent;
pub mod opcua_status;
pub mod shdr;

pub use live::{LiveInfo, LiveServer};
pub use mqtt::{MqttConfig, MqttPublisher};
#[cfg(feature = "opcua")]
pub use opcua::OpcUaServer;
#[cfg(not(feature = "opcua"))]
pub use opcua_absent::OpcUaServer;
pub use shdr::ShdrServer;
