//! The OPC UA server in a build without the `opcua` feature: [`OpcUaServer::start`] refuses
//! with [`OpcUaError::NotBuilt`], which says how to build it in. `--opcua` and
//! `[telemetry.opcua]` are still parsed and checked, so a run config written for a full
//! build fails at start with that message instead of being ignored.

use std::net::SocketAddr;
use std::path::Path;

use acc_runtime::opcua_config::OpcUaSettings;
use acc_runtime::tap::Subscriber;

pub use crate::opcua_status::{ClientCounts, OpcUaError, OpcUaStats};

/// No server can exist in this build: the type has no values.
#[derive(Debug)]
pub enum OpcUaServer {}

impl OpcUaServer {
    /// Always [`OpcUaError::NotBuilt`].
    pub fn start(
        _cfg: &OpcUaSettings,
        _pki_dir: &Path,
        _sub: Subscriber,
    ) -> Result<Self, OpcUaError> {
        Err(OpcUaError::NotBuilt)
    }

    /// Address the server listens on.
    pub fn local_addr(&self) -> SocketAddr {
        match *self {}
    }

    /// `opc.tcp://…` URL of the endpoint.
    pub fn url(&self) -> String {
        match *self {}
    }

    /// The certificate folder.
    pub fn pki_dir(&self) -> &Path {
        match *self {}
    }

    /// Whether the endpoint is Basic256Sha256 with a user.
    pub fn is_secure(&self) -> bool {
        match *self {}
    }

    /// The server's counters.
    pub fn stats(&self) -> &OpcUaStats {
        match *self {}
    }

    /// The server's client counts.
    pub fn clients(&self) -> ClientCounts {
        match *self {}
    }

    /// Stop the server.
    pub fn stop(self) -> ClientCounts {
        match self {}
    }
}
