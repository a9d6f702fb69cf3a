//! Needs LinuxCNC (Debian `linuxcnc-uspace`): absent, the test prints `SKIP: …` and passes,
//! unless `CI` is set, then it fails.
//!
//! acc-hal's component inside LinuxCNC's realtime environment, checked with LinuxCNC's own
//! `halcmd`: values `halcmd setp` / `sets` writes reach the component's input pin, values the
//! component writes are read by `halcmd getp` and by a realtime component (`scale`, on a
//! 1 ms thread in `rtapi_app`), and a dropped component leaves HAL (`halcmd show comp`).
//!
//! `rtapi_app` refuses to run as root unless `RTAPI_UID` names a fallback user; as root
//! (CI) the test gives it `nobody`'s UID and a socket path that user can create
//! (`RTAPI_FIFO_PATH`), the way `rtapi_app`'s own message suggests.

use std::fs::File;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use acc_hal::{HalComponent, HalError};

/// The component's name, unique to this test.
const COMP: &str = "acc-hal-test";
/// LinuxCNC's script that starts and stops the realtime environment (`halrun` calls it).
const REALTIME: &str = "/usr/lib/linuxcnc/realtime";

#[test]
fn halcmd_reads_and_writes_the_components_pins_and_sees_it_leave() {
    if let Some(reason) = missing_linuxcnc() {
        if std::env::var_os("CI").is_some() {
            panic!("LinuxCNC is required under CI: {reason} (run `bash .ci/deps`)");
        }
        eprintln!("SKIP: {reason} (run `bash .ci/deps`); HAL component test not run");
        return;
    }
    let rt = Realtime::start();

    let comp = HalComponent::new(COMP).expect("hal_init");
    let input = comp.float_in("in").expect("float in");
    let mut output = comp.float_out("out").expect("float out");
    let mut flag = comp.bit_out("flag").expect("bit out");
    assert_eq!(
        HalComponent::new(COMP).expect_err("a second component of the same name"),
        HalError::ComponentNameTaken { name: COMP.into() }
    );
    assert_eq!(
        comp.float_in("in")
            .expect_err("a second pin of the same name"),
        HalError::PinNameTaken {
            name: format!("{COMP}.in")
        }
    );
    comp.ready().expect("hal_ready");
    assert!(matches!(
        comp.float_in("late"),
        Err(HalError::AlreadyReady { .. })
    ));
    let listed = rt.component_line(COMP).expect("the component is listed");
    assert!(listed.contains("ready"), "{listed}");
    assert!(listed.contains(&std::process::id().to_string()), "{listed}");

    // halcmd → component: on the pin's own value, then through a signal.
    rt.halcmd(&["setp", &format!("{COMP}.in"), "2.5"]);
    assert_eq!(input.get(), 2.5);
    rt.halcmd(&["net", "acc-test-in", &format!("{COMP}.in")]);
    rt.halcmd(&["sets", "acc-test-in", "-4.25"]);
    assert_eq!(input.get(), -4.25);

    // component → halcmd.
    output.set(1.75);
    flag.set(true);
    assert_eq!(rt.getp(&format!("{COMP}.out")), "1.75");
    assert_eq!(rt.getp(&format!("{COMP}.flag")), "TRUE");
    flag.set(false);
    assert_eq!(rt.getp(&format!("{COMP}.flag")), "FALSE");

    // component → a realtime component on the servo thread → halcmd.
    rt.halcmd(&[
        "net",
        "acc-test-out",
        &format!("{COMP}.out"),
        "acc-test-scale.in",
    ]);
    rt.halcmd(&["setp", "acc-test-scale.gain", "2"]);
    rt.wait_for_value("acc-test-scale.out", "3.5");

    drop((input, output, flag, comp));
    assert_eq!(
        rt.component_line(COMP),
        None,
        "hal_exit removes the component"
    );
    assert_eq!(rt.getp_result(&format!("{COMP}.out")), None);
}

/// Why LinuxCNC cannot be used here, or `None` when its HAL library and tools are installed.
fn missing_linuxcnc() -> Option<String> {
    if let Err(err) = acc_hal::probe_library() {
        return Some(err.to_string());
    }
    if !Path::new(REALTIME).exists() {
        return Some(format!("{REALTIME} is not installed"));
    }
    match Command::new("halcmd").arg("-v").output() {
        Ok(_) => None,
        Err(err) => Some(format!("halcmd does not run: {err}")),
    }
}

/// LinuxCNC's realtime environment with a 1 ms thread `acc-test-servo` running a `scale`
/// named `acc-test-scale`; stopped (`halcmd stop`, `unload all`, `realtime stop`) on drop.
struct Realtime {
    /// Environment for `halcmd`, `rtapi_app` and the `realtime` script.
    env: Vec<(&'static str, String)>,
}

impl Realtime {
    /// Starts realtime and the thread; panics (the test fails) when LinuxCNC's own tools do.
    fn start() -> Self {
        let fifo = std::env::temp_dir().join("acc-hal-test.rtapi_fifo");
        let mut env = vec![("RTAPI_FIFO_PATH", fifo.display().to_string())];
        if stdout_of("id", &["-u"], output("id", &["-u"], &[])).trim() == "0" {
            let nobody = stdout_of("id", &["nobody"], output("id", &["-u", "nobody"], &[]));
            env.push(("RTAPI_UID", nobody.trim().to_string()));
        }
        let rt = Self { env };
        if rt.run(REALTIME, &["status"]).status.success() {
            panic!("LinuxCNC's realtime is already running here: stop it (halrun -U) first");
        }
        // A previous run that died leaves HAL's shared memory behind; `stop` removes it.
        rt.run(REALTIME, &["stop"]);
        rt.checked(REALTIME, &["start"]);
        rt.halcmd(&[
            "loadrt",
            "threads",
            "name1=acc-test-servo",
            "period1=1000000",
        ]);
        rt.halcmd(&["loadrt", "scale", "names=acc-test-scale"]);
        rt.halcmd(&["addf", "acc-test-scale", "acc-test-servo"]);
        rt.halcmd(&["start"]);
        rt
    }

    /// Runs `halcmd ARGS`, failing the test if it fails; its stdout.
    fn halcmd(&self, args: &[&str]) -> String {
        self.checked("halcmd", args)
    }

    /// `halcmd getp PIN`, trimmed; fails the test if the pin does not exist.
    fn getp(&self, pin: &str) -> String {
        self.getp_result(pin)
            .unwrap_or_else(|| panic!("halcmd getp {pin} failed"))
    }

    /// `halcmd getp PIN`, trimmed, or `None` when halcmd finds no such pin.
    fn getp_result(&self, pin: &str) -> Option<String> {
        let out = self.run("halcmd", &["getp", pin]);
        out.status
            .success()
            .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
    }

    /// Polls `halcmd getp PIN` until it reads `expected` (the realtime thread runs each
    /// millisecond); fails the test after 2 s.
    fn wait_for_value(&self, pin: &str, expected: &str) {
        let deadline = Instant::now() + Duration::from_secs(2);
        loop {
            let value = self.getp(pin);
            if value == expected {
                return;
            }
            assert!(
                Instant::now() < deadline,
                "{pin} reads {value}, not {expected}, after 2 s"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// The `halcmd -s show comp` line of component `name`, if it is loaded.
    fn component_line(&self, name: &str) -> Option<String> {
        self.halcmd(&["-s", "show", "comp"])
            .lines()
            .find(|line| line.split_whitespace().nth(2) == Some(name))
            .map(str::to_string)
    }

    /// Runs `program ARGS` with the realtime environment; its output, success or not.
    fn run(&self, program: &str, args: &[&str]) -> Output {
        output(program, args, &self.env)
    }

    /// Runs `program ARGS`, failing the test with its stderr if it fails; its stdout.
    fn checked(&self, program: &str, args: &[&str]) -> String {
        stdout_of(program, args, self.run(program, args))
    }
}

impl Drop for Realtime {
    fn drop(&mut self) {
        for (program, args) in [
            ("halcmd", &["stop"][..]),
            ("halcmd", &["unload", "all"][..]),
            (REALTIME, &["stop"][..]),
        ] {
            self.run(program, args);
        }
    }
}

/// Runs `program ARGS` with `env` added; its output, success or not. Output goes through
/// files, not pipes: the `rtapi_app` that `halcmd loadrt` starts keeps running with the
/// inherited descriptors, so a pipe would never reach its end.
fn output(program: &str, args: &[&str], env: &[(&'static str, String)]) -> Output {
    let dir = tempfile::tempdir().expect("temporary directory");
    let (out_path, err_path) = (dir.path().join("stdout"), dir.path().join("stderr"));
    let file = |path: &Path| File::create(path).expect("output file");
    let status = Command::new(program)
        .args(args)
        .envs(env.iter().map(|(key, value)| (*key, value.as_str())))
        .stdin(Stdio::null())
        .stdout(file(&out_path))
        .stderr(file(&err_path))
        .status()
        .unwrap_or_else(|err| panic!("{program} does not start: {err}"));
    let read = |path: &Path| std::fs::read(path).expect("read output file");
    Output {
        status,
        stdout: read(&out_path),
        stderr: read(&err_path),
    }
}

/// The stdout of `program ARGS`'s `out`; fails the test with its stderr if it failed.
fn stdout_of(program: &str, args: &[&str], out: Output) -> String {
    assert!(
        out.status.success(),
        "{program} {} failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}
