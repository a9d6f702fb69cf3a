//! `acc report` on a log written by `acc sim` (the production loop on the simulated
//! machine, a tool that breaks mid-cut), opened in headless Chromium with the network off:
//! the rendered DOM holds the per-cut table's rows, the alarms and the inline SVG plots, and
//! the page references nothing outside itself.
//!
//! Needs `/usr/bin/chromium` (`bash .ci/deps` installs it): without it the test prints a
//! skip reason and passes; with `CI` set it fails instead.

use std::path::Path;
use std::process::Command;

use crate::e2e_support::{acc_bin, root};

fn chromium() -> Option<&'static str> {
    let bin = "/usr/bin/chromium";
    if Path::new(bin).exists() {
        return Some(bin);
    }
    if std::env::var_os("CI").is_some() {
        panic!("{bin} is not installed but CI is set: run `bash .ci/deps`");
    }
    eprintln!(
        "SKIP: {bin} is not installed (run `bash .ci/deps`); acc report not opened in a browser"
    );
    None
}

fn acc(args: &[&str]) -> String {
    let out = Command::new(acc_bin())
        .current_dir(root())
        .args(args)
        .output()
        .expect("run acc");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "acc {args:?} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

#[test]
fn acc_report_of_an_acc_sim_log_renders_in_headless_chromium() {
    let Some(chromium) = chromium() else { return };
    let dir = tempfile::tempdir().expect("tmp");
    let sim = dir.path().join("sim");
    let sim_s = sim.to_string_lossy().into_owned();
    acc(&["sim", "tool_breakage", "--out", &sim_s, "--no-plot"]);
    let log = sim.join("run.csv");
    let rep = dir.path().join("report");
    let stdout = acc(&[
        "report",
        &log.to_string_lossy(),
        "--out",
        &rep.to_string_lossy(),
    ]);
    assert!(stdout.contains("1 cuts"), "{stdout}");
    let page = rep.join("report.html");
    let html = std::fs::read_to_string(&page).expect("report.html");
    // Self-contained: no scripts, no links or sources outside the page.
    for bad in ["<script", "src=\"http", "href=\"http", "url(http", "<link"] {
        assert!(!html.contains(bad), "the page references `{bad}`");
    }
    let profile = dir.path().join("chromium-profile");
    let out = Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            "--window-size=1100,1600",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg("--dump-dom")
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("run chromium");
    let dom = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "chromium failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The per-cut table: one cut (the long 3 mm cut, ended by the breakage), with its alarm.
    let cut_rows = dom.matches("<tr class=\"cut\">").count();
    assert_eq!(cut_rows, 1, "cut rows in the DOM");
    let row = dom
        .split("<tr class=\"cut\">")
        .nth(1)
        .and_then(|r| r.split("</tr>").next())
        .expect("cut row");
    assert!(row.contains("breakage") && row.contains("1000"), "{row}");
    assert!(dom.contains("<tr class=\"alarm\"><td>1</td>"), "alarm row");
    // The plots, inline: the run figure (force along the path etc.) and the stored trend.
    assert!(dom.contains("id=\"plot-run\""), "run plot");
    assert!(dom.contains("id=\"plot-trend\""), "trend plot");
    assert!(dom.matches("<svg").count() >= 2, "inline SVG plots");
    assert!(dom.contains("force [N]") && dom.contains("override [%]"));
}
