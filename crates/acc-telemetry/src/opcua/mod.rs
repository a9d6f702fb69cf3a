//! OPC UA server (async-opcua): the information model of [`model`] (after OPC 40501 / 40502),
//! its values updated from every record of a [`Subscriber`] of the runtime's tap, alarms and
//! state changes as events ([`events`]), anonymous / SecurityPolicy None or
//! Basic256Sha256 with a user ([`security`]). docs/opcua.md.
//!
//! Threads: the server runs on a tokio runtime of its own (one worker, `acc-opcua`); the
//! feeder thread (`opcua-feed`) reads the subscriber and writes each record's values into the
//! address space, which queues a notification for each monitored item. The control loop only
//! ever publishes to the tap, which never waits: a feeder that falls behind loses records
//! from its tap queue (counted, [`OpcUaStats::records_dropped`]), and a client that reads
//! slower than the queue it asked for loses the oldest values of it (the server sets the
//! OPC UA Overflow bit on the next one: the client sees it; the crate has no per-client
//! hook to count it here). Dead clients are counted as the sessions the server timed out.

pub mod events;
pub mod model;
pub mod security;

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use acc_runtime::opcua_config::OpcUaSettings;
use acc_runtime::tap::Subscriber;
use crossbeam_channel::RecvTimeoutError;

use opcua::nodes::{BaseEventType, Event};
use opcua::server::diagnostics::NamespaceMetadata;
use opcua::server::node_manager::memory::{simple_node_manager, SimpleNodeManager};
use opcua::server::{ServerBuilder, ServerHandle};
use opcua::types::{ByteString, DateTime, LocalizedText, ObjectTypeId, VariableId};

pub use model::{Model, NAMESPACE};

/// Largest queue a client may ask for on one monitored item, values (100 s at T = 0.1 s).
pub const MAX_ITEM_QUEUE: usize = 1000;

/// How long [`OpcUaServer::stop`] leaves the sessions open after the last record.
pub const LAST_PUBLISH: Duration = Duration::from_millis(300);

pub use crate::opcua_status::{ClientCounts, OpcUaError, OpcUaStats};

/// A running OPC UA server; [`OpcUaServer::stop`] ends it.
pub struct OpcUaServer {
    rt: Option<tokio::runtime::Runtime>,
    handle: ServerHandle,
    addr: SocketAddr,
    pki_dir: PathBuf,
    secure: bool,
    stats: Arc<OpcUaStats>,
    refusals: Arc<security::RefusalLog>,
    stop: Arc<AtomicBool>,
    feeder: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for OpcUaServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OpcUaServer")
            .field("addr", &self.addr)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

fn host_for(addr: SocketAddr) -> String {
    if addr.ip().is_unspecified() {
        opcua::crypto::X509Data::computer_hostnames()
            .into_iter()
            .next()
            .unwrap_or_else(|| "localhost".into())
    } else {
        addr.ip().to_string()
    }
}

impl OpcUaServer {
    /// Listen on `cfg.addr` and serve the records of `sub`; certificates live in `pki_dir`
    /// (created on first start). Fails at once, with the address, if the port is taken.
    pub fn start(cfg: &OpcUaSettings, pki_dir: &Path, sub: Subscriber) -> Result<Self, OpcUaError> {
        let password = match &cfg.user {
            Some(u) => Some(security::read_password(u).map_err(OpcUaError::Password)?),
            None => None,
        };
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("acc-opcua")
            .enable_all()
            .build()
            .map_err(OpcUaError::Runtime)?;
        let listener = rt
            .block_on(tokio::net::TcpListener::bind(cfg.addr))
            .map_err(|source| OpcUaError::Listen {
                addr: cfg.addr,
                source,
            })?;
        let addr = listener.local_addr().map_err(OpcUaError::Runtime)?;
        let host = host_for(addr);
        let refusals = Arc::new(security::RefusalLog::default());
        let mut builder = ServerBuilder::new()
            .application_name("acc adaptive feed-override controller")
            .application_uri("urn:acc:opcua:server")
            .product_uri("urn:acc")
            .host(host.clone())
            .port(addr.port())
            .discovery_urls(vec![format!("opc.tcp://{host}:{}/", addr.port())])
            .diagnostics_enabled(true)
            .with_node_manager(simple_node_manager(
                NamespaceMetadata {
                    namespace_uri: NAMESPACE.into(),
                    ..Default::default()
                },
                "acc",
            ));
        {
            let l = &mut builder.limits_mut().subscriptions;
            // Every period's value is a sample: no sampling interval filters it.
            l.min_sampling_interval_ms = 0.0;
            l.max_monitored_item_queue_size = MAX_ITEM_QUEUE;
            l.max_queued_notifications = 20 * MAX_ITEM_QUEUE;
        }
        let builder =
            security::secure(builder, cfg, password.as_deref(), pki_dir, refusals.clone());
        // The server's builder spawns its status sampler: inside the runtime.
        let (server, handle) = {
            let _in_runtime = rt.enter();
            builder.build().map_err(OpcUaError::Server)?
        };
        let nm = handle
            .node_managers()
            .get_of_type::<SimpleNodeManager>()
            .ok_or_else(|| OpcUaError::Server("no node manager for the acc namespace".into()))?;
        let ns = handle
            .get_namespace_index(NAMESPACE)
            .ok_or_else(|| OpcUaError::Server(format!("namespace {NAMESPACE} not registered")))?;
        let model = Model::build(&mut nm.address_space().write(), ns);
        rt.spawn(async move {
            if let Err(e) = server.run_with(listener).await {
                tracing::error!(error = %e, "OPC UA server ended");
            }
        });

        let stats = Arc::new(OpcUaStats::default());
        let stop = Arc::new(AtomicBool::new(false));
        let feeder = {
            let (stats, stop, handle) = (stats.clone(), stop.clone(), handle.clone());
            std::thread::Builder::new()
                .name("opcua-feed".into())
                .spawn(move || feed(&sub, &nm, &handle, &model, &stats, &stop))
                .map_err(OpcUaError::Runtime)?
        };
        tracing::info!(%addr, secure = cfg.user.is_some(), "OPC UA server started");
        Ok(Self {
            rt: Some(rt),
            handle,
            addr,
            pki_dir: pki_dir.to_path_buf(),
            secure: cfg.user.is_some(),
            stats,
            refusals,
            stop,
            feeder: Some(feeder),
        })
    }

    /// The address the server listens on (the actual port when `:0` was asked).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// The endpoint URL (`opc.tcp://IP:PORT/`).
    pub fn url(&self) -> String {
        OpcUaSettings::url_for(self.addr)
    }

    /// Where the certificates are.
    pub fn pki_dir(&self) -> &Path {
        &self.pki_dir
    }

    /// Whether the only endpoint is Basic256Sha256 with a user.
    pub fn is_secure(&self) -> bool {
        self.secure
    }

    /// Counters.
    pub fn stats(&self) -> &OpcUaStats {
        &self.stats
    }

    /// The clients as the server's diagnostics count them.
    pub fn clients(&self) -> ClientCounts {
        let d = &self.handle.info().diagnostics;
        let get = |id: VariableId| -> u64 {
            d.get(id)
                .and_then(|v| v.value)
                .and_then(|v| match v {
                    opcua::types::Variant::UInt32(x) => Some(u64::from(x)),
                    _ => None,
                })
                .unwrap_or(0)
        };
        use VariableId as V;
        ClientCounts {
            current: get(V::Server_ServerDiagnostics_ServerDiagnosticsSummary_CurrentSessionCount),
            cumulated: get(
                V::Server_ServerDiagnostics_ServerDiagnosticsSummary_CumulatedSessionCount,
            ),
            timed_out: get(
                V::Server_ServerDiagnostics_ServerDiagnosticsSummary_SessionTimeoutCount,
            ),
            security_rejected: get(
                V::Server_ServerDiagnostics_ServerDiagnosticsSummary_SecurityRejectedSessionCount,
            ),
            auth_refused: self.refusals.refused(),
        }
    }

    /// Stop: the feeder writes what is queued, then the server closes its sessions.
    pub fn stop(mut self) -> ClientCounts {
        self.shutdown()
    }

    fn shutdown(&mut self) -> ClientCounts {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(f) = self.feeder.take() {
            let _ = f.join();
        }
        let counts = self.clients();
        if counts.current > 0 {
            // One more publishing cycle (the server polls every 100 ms), so that subscribed
            // clients get the last period's values before their sessions close.
            std::thread::sleep(LAST_PUBLISH);
        }
        self.handle.cancel();
        if let Some(rt) = self.rt.take() {
            rt.shutdown_timeout(Duration::from_secs(2));
        }
        counts
    }
}

impl Drop for OpcUaServer {
    fn drop(&mut self) {
        if self.rt.is_some() {
            self.shutdown();
        }
    }
}

/// The feeder: each record's values into the address space (notifying the monitored items),
/// and its events to the event notifiers.
fn feed(
    sub: &Subscriber,
    nm: &SimpleNodeManager,
    handle: &ServerHandle,
    model: &Model,
    stats: &OpcUaStats,
    stop: &AtomicBool,
) {
    let subs = handle.subscriptions();
    let mut ev_feed = events::EventFeed::default();
    // Source timestamps: the wall time of the first record, then the records' machine time.
    let mut t0: Option<(DateTime, f64)> = None;
    let mut seq = 0u64;
    loop {
        match sub.recv_timeout(Duration::from_millis(50)) {
            Ok(r) => {
                stats
                    .records_dropped
                    .store(sub.dropped(), Ordering::Relaxed);
                let (wall0, t_s0) = *t0.get_or_insert_with(|| (DateTime::now(), r.t_s));
                let dt = if r.t_s.is_finite() { r.t_s - t_s0 } else { 0.0 };
                // DateTime ticks are 100 ns.
                let at = DateTime::from(wall0.ticks() + (dt * 1e7).round() as i64);
                let values = model.values(&r, at).map(|(id, dv)| (id, None, dv));
                if let Err(e) = nm.set_values(subs, values) {
                    tracing::warn!(status = %e, "OPC UA: a value was not written");
                }
                stats.records.fetch_add(1, Ordering::Relaxed);
                for e in ev_feed.push(&r) {
                    seq += 1;
                    let mut id = seq.to_be_bytes().to_vec();
                    id.extend_from_slice(&e.period.to_be_bytes());
                    let evt = BaseEventType::new(
                        ObjectTypeId::BaseEventType,
                        ByteString::from(id),
                        LocalizedText::from(e.message.as_str()),
                        at,
                    )
                    .set_source_node(model.event_source())
                    .set_source_name("acc".into())
                    .set_severity(e.severity);
                    // Notified on `Acc`; the server passes every event on to `Server` too.
                    let source = model.event_source();
                    subs.notify_events(std::iter::once((&evt as &dyn Event, &source)));
                    stats.events.fetch_add(1, Ordering::Relaxed);
                }
            }
            Err(RecvTimeoutError::Timeout) => {
                if stop.load(Ordering::SeqCst) {
                    break;
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                if stop.load(Ordering::SeqCst) {
                    break;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        }
    }
}
