//! A real `mosquitto` broker for the MQTT tests: a free port, the binary, start and stop.
#![allow(dead_code)]

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A free TCP port on 127.0.0.1.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// `mosquitto` on PATH, or Debian's `/usr/sbin/mosquitto` (not on a user's PATH).
pub fn mosquitto() -> String {
    let on_path = Command::new("sh")
        .args(["-c", "command -v mosquitto"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    on_path.unwrap_or_else(|| "/usr/sbin/mosquitto".into())
}

/// A running broker, killed on drop.
pub struct Broker {
    child: Child,
}

impl Broker {
    /// Start `mosquitto -c conf` and wait until it listens on `port` (at most 5 s).
    pub fn start(conf: &std::path::Path, port: u16) -> Self {
        let child = Command::new(mosquitto())
            .arg("-c")
            .arg(conf)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("mosquitto");
        let t0 = Instant::now();
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(
                t0.elapsed() < Duration::from_secs(5),
                "mosquitto did not start"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        Self { child }
    }
}

impl Broker {
    /// Stop the broker as an operator would (SIGTERM: it saves its persistent sessions) and
    /// wait for it to exit.
    pub fn terminate(&mut self) {
        let _ = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status();
        let _ = self.child.wait();
    }
}

impl Drop for Broker {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Write a broker config for `127.0.0.1:port` (anonymous, no persistence) into `dir`.
pub fn write_conf(dir: &std::path::Path, port: u16) -> std::path::PathBuf {
    let conf = dir.join("mosquitto.conf");
    std::fs::write(
        &conf,
        format!("listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n"),
    )
    .expect("mosquitto.conf");
    conf
}

/// Whether mosquitto is installed (else the skip reason is printed, or CI fails).
pub fn mosquitto_ready() -> bool {
    super::e2e_support::peer_ready(
        "mosquitto (apt package mosquitto)",
        Command::new("test").args(["-x", &mosquitto()]),
    )
}

/// Write a broker config for `127.0.0.1:port` that keeps its sessions and queued messages
/// across a restart (`persistence true`, the database in `dir`). `user root` keeps a broker
/// started as root from dropping to the `mosquitto` user, who could not write into the
/// test's private temporary folder (a broker not started as root ignores it).
pub fn write_persistent_conf(dir: &std::path::Path, port: u16) -> std::path::PathBuf {
    let conf = dir.join("mosquitto-persistent.conf");
    std::fs::write(
        &conf,
        format!(
            "listener {port} 127.0.0.1\nallow_anonymous true\nuser root\npersistence true\npersistence_location {}/\n",
            dir.display()
        ),
    )
    .expect("mosquitto.conf");
    conf
}
