//! Needs LinuxCNC (Debian `linuxcnc-uspace`): absent, the test prints `SKIP: …` and passes,
//! unless `CI` is set, then it fails.
//!
//! [`HalPins`] on LinuxCNC's HAL, driven by LinuxCNC's own `halcmd`: every pin exists under
//! its documented name, values `halcmd setp` writes reach [`HalBoard`]'s status, and the
//! adaptive feed and heartbeat it writes are read back with `halcmd getp`. Only HAL's shared
//! memory is used (no realtime thread), so `rtapi_app` is not started.

use std::process::Command;

use acc_hal::HalComponent;
use acc_linuxcnc::{HalBoard, HalPins};
use acc_pmc::{Board, ControlBits};

/// The component's name, unique to this test.
const COMP: &str = "acc-lcnc-test";

#[test]
fn halcmd_drives_hal_board_through_its_pins() {
    if let Some(reason) = missing_linuxcnc() {
        if std::env::var_os("CI").is_some() {
            panic!("LinuxCNC is required under CI: {reason} (run `bash .ci/deps`)");
        }
        eprintln!("SKIP: {reason} (run `bash .ci/deps`); HalPins test not run");
        return;
    }
    let pins = HalPins::new(HalComponent::new(COMP).expect("hal_init")).expect("pins");
    let listed = halcmd(&["-s", "show", "pin", COMP]);
    let count = listed
        .lines()
        .filter(|line| !line.trim().is_empty())
        .count();
    assert_eq!(count, 25, "{listed}");

    for (pin, value) in [
        ("spindle-power", "2500"),
        ("spindle-speed", "8000"),
        ("program-line", "17"),
        ("motion-type", "2"),
        ("feed-override", "1.5"),
        ("requested-vel", "10"),
        ("machine-on", "1"),
        ("program-running", "1"),
        ("mode-auto", "1"),
        ("adaptive-enabled", "1"),
        ("enable", "1"),
        ("watchdog-ok", "1"),
        ("sample-seq", "70001"),
        ("sample-seq-used", "1"),
    ] {
        halcmd(&["setp", &format!("{COMP}.{pin}"), value]);
    }
    let mut board = HalBoard::new(pins);
    board
        .write_control(ControlBits {
            acc_request: true,
            ..ControlBits::default()
        })
        .expect("control");
    let status = board.read_status().expect("status");
    assert_eq!(status.spindle_power_w, 2_500);
    assert_eq!(status.spindle_rpm, 8_000);
    assert_eq!(status.block_number, 17);
    assert_eq!(status.programmed_feed_mm_min, 600);
    assert_eq!(status.operator_override_pct, 150);
    let seq = status.sample_seq;
    assert_eq!(
        board.read_status().expect("status").sample_seq,
        seq,
        "counter still"
    );
    halcmd(&["setp", &format!("{COMP}.sample-seq"), "70050"]);
    assert_eq!(
        board.read_status().expect("status").sample_seq,
        seq.wrapping_add(1),
        "the counter moved: one new sample"
    );
    assert!(status.acc_active && status.cycle_active);

    board.write_override(75, 7).expect("override");
    assert_eq!(
        halcmd(&["getp", &format!("{COMP}.adaptive-feed")]).trim(),
        "0.5"
    );
    assert_eq!(halcmd(&["getp", &format!("{COMP}.heartbeat")]).trim(), "7");
    // The watchdog's bit toggles at every period's status read.
    let bit = halcmd(&["getp", &format!("{COMP}.heartbeat-bit")]);
    board.read_status().expect("status");
    let toggled = halcmd(&["getp", &format!("{COMP}.heartbeat-bit")]);
    assert_ne!(bit.trim(), toggled.trim(), "{bit} then {toggled}");
    assert_eq!(halcmd(&["getp", &format!("{COMP}.active")]).trim(), "TRUE");

    drop(board);
    assert_eq!(
        halcmd(&["-s", "show", "pin", COMP]).trim(),
        "",
        "the pins leave HAL"
    );
}

/// Why LinuxCNC cannot be used here, or `None` when its HAL library and halcmd are installed.
fn missing_linuxcnc() -> Option<String> {
    if let Err(err) = acc_hal::probe_library() {
        return Some(err.to_string());
    }
    match Command::new("halcmd").arg("-v").output() {
        Ok(_) => None,
        Err(err) => Some(format!("halcmd does not run: {err}")),
    }
}

/// `halcmd ARGS`' stdout; fails the test with its stderr if it fails.
fn halcmd(args: &[&str]) -> String {
    let out = Command::new("halcmd")
        .args(args)
        .output()
        .expect("halcmd starts");
    assert!(
        out.status.success(),
        "halcmd {} failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}
