//! What the OPC UA server reports — why it did not start, its counters, its clients — in
//! every build, with or without the `opcua` feature (the server itself is the `opcua`
//! module with the feature, `opcua_absent` without it).

use std::net::SocketAddr;
use std::sync::atomic::AtomicU64;

/// Why the server did not start.
#[derive(Debug, thiserror::Error)]
pub enum OpcUaError {
    /// The listen address is taken or not ours.
    #[error("OPC UA: cannot listen on {addr}")]
    Listen {
        /// Address asked for.
        addr: SocketAddr,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The password file cannot be read.
    #[error("{0}")]
    Password(String),
    /// The server could not be built (configuration, certificates).
    #[error("OPC UA server: {0}")]
    Server(String),
    /// No tokio runtime or thread.
    #[error("OPC UA server: {0}")]
    Runtime(std::io::Error),
    /// This `acc` was built without the OPC UA server.
    #[error("this acc was built without the OPC UA server: build it with `cargo build --release -p acc-cli --features opcua` (or `--features full`)")]
    NotBuilt,
}

/// Counters of a running server.
#[derive(Debug, Default)]
pub struct OpcUaStats {
    /// Records written into the address space.
    pub records: AtomicU64,
    /// Events sent (alarm raised / cleared, state change).
    pub events: AtomicU64,
    /// Records the feeder lost because its tap queue was full.
    pub records_dropped: AtomicU64,
}

/// What the server's diagnostics say about its clients (read at [`OpcUaServer::clients`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ClientCounts {
    /// Sessions open now.
    pub current: u64,
    /// Sessions opened since the start.
    pub cumulated: u64,
    /// Sessions closed by the server because the client went silent (dead clients).
    pub timed_out: u64,
    /// Sessions or requests refused for security (bad certificate, wrong password, …).
    pub security_rejected: u64,
    /// Identities refused (wrong password, unknown user, anonymous on the secure endpoint),
    /// each also logged.
    pub auth_refused: u64,
}
