//! What the shop-floor network hears: MQTT to a real broker, OPC UA to asyncua and
//! node-opcua, MTConnect SHDR, the live view and the HTML report in a headless browser.
//!
//! One module per test file; shared helpers in `tests/support/`.

#[path = "../support/e2e.rs"]
mod e2e_support;
#[path = "../support/mqtt.rs"]
mod mqtt_support;

mod live_view;
mod mqtt;
mod opcua;
mod report_browser;
mod shdr;
