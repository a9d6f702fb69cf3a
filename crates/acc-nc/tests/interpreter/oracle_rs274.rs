//! Needs LinuxCNC's stand-alone interpreter `rs274` (Debian `linuxcnc-uspace`, `.ci/deps`)
//! and, for the third-party programs, `../shared/data/nc/`: without them the test prints
//! `SKIP: …` and passes, unless `CI` is set, then it fails.
//!
//! The oracle test: every program in `tests/nc/` (ours) and `../shared/data/nc/` (LinuxCNC's,
//! read in place, never copied) runs through `rs274 -g` and through `acc_nc::interpret`.
//! For every program both accept: the same sequence of motions (traverse, feed, arc), every
//! end point, every arc centre and turn count, every feed and every tool length offset agree
//! to the 4 decimals `rs274` prints, and every motion carries the same N number. A program we refuse must be one `rs274` accepts only
//! because of a feature we refuse by name (listed in `REFUSED`), with that name in our error.

use std::path::{Path, PathBuf};
use std::process::Command;

use acc_nc::{interpret, Canon, Plane, Setup, ToolTable, Units};

/// Third-party programs we refuse, and the word our error must name (none at present).
const REFUSED: &[(&str, &str)] = &[];

/// Work offsets of G54…G59 for the test, mm (written to rs274's parameter file in inches).
const OFFSETS_MM: [[f64; 3]; 6] = [
    [0.0, 0.0, 0.0],
    [100.0, 50.0, -10.0],
    [-25.4, 12.7, 0.0],
    [200.5, -33.25, 5.0],
    [0.0, 300.0, -50.0],
    [12.345, 67.891, -1.5],
];

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn skip_or_fail(reason: &str) {
    if std::env::var_os("CI").is_some() {
        panic!("CI is set and {reason}");
    }
    println!("SKIP: {reason}");
}

fn rs274() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("rs274"))
        .find(|p| p.is_file())
}

/// One motion as rs274 prints it (in the program units of the moment).
#[derive(Debug, Clone, PartialEq)]
struct Motion {
    /// `traverse`, `feed`, or `arc-xy` / `arc-xz` / `arc-yz` (the plane of SELECT_PLANE).
    kind: &'static str,
    /// x, y, z end; for arcs, as ARC_FEED, the ends on the plane's first and second axis
    /// and on its normal, the centre on the first and second axis, and the rotation
    /// (signed turns).
    values: Vec<f64>,
    /// Feed rate in force (program units/min as programmed); 0 for traverses.
    feed: f64,
    /// The block's N number (rs274 prints it before the call; `N.....` for none).
    block: Option<u32>,
}

/// The motions and tool length offsets of rs274's canon output.
fn parse_rs274(out: &str) -> (Vec<Motion>, Vec<f64>) {
    let mut motions = Vec::new();
    let mut tlo = Vec::new();
    let mut feed = 0.0;
    let mut arc = "arc-xy";
    for line in out.lines() {
        let Some(open) = line.find('(') else { continue };
        let name = line[..open].split_whitespace().last().unwrap_or("");
        let block = line
            .split_whitespace()
            .nth(1)
            .and_then(|t| t.strip_prefix('N'))
            .and_then(|d| d.parse::<u32>().ok());
        let args: Vec<f64> = line[open + 1..line.rfind(')').unwrap_or(line.len())]
            .split([',', ' '])
            .filter_map(|s| s.trim().parse().ok())
            .collect();
        match name {
            "SET_FEED_RATE" => feed = args[0],
            "SELECT_PLANE" => {
                arc = match &line[open..] {
                    p if p.contains("XZ") => "arc-xz",
                    p if p.contains("YZ") => "arc-yz",
                    _ => "arc-xy",
                }
            }
            "USE_TOOL_LENGTH_OFFSET" => tlo.push(args[2]),
            "STRAIGHT_TRAVERSE" => motions.push(Motion {
                kind: "traverse",
                values: args[..3].to_vec(),
                feed: 0.0,
                block,
            }),
            "STRAIGHT_FEED" => motions.push(Motion {
                kind: "feed",
                values: args[..3].to_vec(),
                feed,
                block,
            }),
            "ARC_FEED" => motions.push(Motion {
                kind: arc,
                values: vec![args[0], args[1], args[5], args[2], args[3], args[4]],
                feed,
                block,
            }),
            _ => {}
        }
    }
    (motions, tlo)
}

/// Our motions and tool length offsets in rs274's terms: lengths in the program units in
/// force, feeds as programmed.
fn ours(calls: &[acc_nc::CanonCall]) -> (Vec<Motion>, Vec<f64>) {
    let mut motions = Vec::new();
    let mut tlo = Vec::new();
    let mut unit = 1.0;
    let mut feed = 0.0;
    for c in calls {
        match &c.call {
            Canon::Units { units } => unit = units.mm_per_unit(),
            Canon::FeedRate { programmed, .. } => feed = *programmed,
            Canon::ToolLengthOffset { z_mm } => tlo.push(z_mm / unit),
            Canon::Traverse { to, .. } => motions.push(Motion {
                kind: "traverse",
                values: to.iter().map(|v| v / unit).collect(),
                feed: 0.0,
                block: c.block,
            }),
            Canon::Feed { to, .. } => motions.push(Motion {
                kind: "feed",
                values: to.iter().map(|v| v / unit).collect(),
                feed,
                block: c.block,
            }),
            Canon::Arc {
                to,
                center,
                plane,
                clockwise,
                turns,
                ..
            } => {
                let rot = f64::from(*turns) * if *clockwise { -1.0 } else { 1.0 };
                let mut values: Vec<f64> = plane.axes().iter().map(|&a| to[a] / unit).collect();
                values.extend([center[0] / unit, center[1] / unit, rot]);
                motions.push(Motion {
                    kind: match plane {
                        Plane::Xy => "arc-xy",
                        Plane::Xz => "arc-xz",
                        Plane::Yz => "arc-yz",
                    },
                    values,
                    feed,
                    block: c.block,
                });
            }
            _ => {}
        }
    }
    (motions, tlo)
}

/// Agreement to rs274's 4 decimals: our exact value rounds to the printed one.
fn agree(ours: f64, printed: f64) -> bool {
    (ours - printed).abs() <= 0.5e-4 + 1e-9 * (1.0 + printed.abs())
}

/// Compares one program; `Err` names the first disagreement.
fn compare(
    name: &str,
    theirs: &(Vec<Motion>, Vec<f64>),
    mine: &(Vec<Motion>, Vec<f64>),
) -> Result<(), String> {
    let (t, m) = (&theirs.0, &mine.0);
    if t.len() != m.len() {
        return Err(format!(
            "{name}: rs274 has {} motions, we have {}",
            t.len(),
            m.len()
        ));
    }
    for (k, (a, b)) in t.iter().zip(m).enumerate() {
        let same = a.kind == b.kind
            && a.values.len() == b.values.len()
            && a.values.iter().zip(&b.values).all(|(x, y)| agree(*y, *x))
            && agree(b.feed, a.feed)
            && a.block == b.block;
        if !same {
            return Err(format!("{name}: motion {k}: rs274 {a:?}, ours {b:?}"));
        }
    }
    if theirs.1.len() != mine.1.len() || theirs.1.iter().zip(&mine.1).any(|(x, y)| !agree(*y, *x)) {
        return Err(format!(
            "{name}: tool length offsets: rs274 {:?}, ours {:?}",
            theirs.1, mine.1
        ));
    }
    Ok(())
}

fn programs(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| rd.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    v.retain(|p| p.extension().is_some_and(|e| e == "ngc"));
    v.sort();
    v
}

#[test]
fn rs274_and_acc_nc_agree_on_every_program() {
    let Some(rs274) = rs274() else {
        skip_or_fail("rs274 (Debian linuxcnc-uspace) is not on PATH; install with .ci/deps");
        return;
    };
    let root = repo_root();
    let ours_dir = root.join("tests/nc");
    let shared = root.join("../shared/data/nc");
    let mut files = programs(&ours_dir);
    if shared.is_dir() {
        files.extend(programs(&shared));
    } else {
        skip_or_fail(&format!(
            "{} is absent: third-party programs not run",
            shared.display()
        ));
    }
    let tbl = root.join("tests/nc/tools.tbl");
    let tbl_text = std::fs::read_to_string(&tbl).expect("tests/nc/tools.tbl");
    // rs274 without an INI file reads the tool table and parameter file in inches.
    let tools = ToolTable::parse_tbl("tools.tbl", &tbl_text, Units::Inch).expect("tool table");
    let setup = Setup {
        tools,
        work_offsets_mm: OFFSETS_MM,
        ..Setup::default()
    };
    // rs274 keeps its tool table in $HOME/.tool.mmap: a private HOME per test, so that
    // parallel runs (and other users of rs274) do not share it.
    let tmp = tempfile::tempdir().expect("temp dir");
    let mut agreed = Vec::new();
    let mut refused = Vec::new();
    let mut failures = Vec::new();
    for file in &files {
        let name = file
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        // rs274 rewrites its parameter file: a fresh copy per program.
        let var = tmp.path().join("offsets.var");
        let mut text = String::from("5220 1\n");
        for (i, o) in OFFSETS_MM.iter().enumerate() {
            for (a, v) in o.iter().enumerate() {
                text += &format!("{} {:.12}\n", 5221 + 20 * i + a, v / 25.4);
            }
        }
        // Our offsets come from the same file, read as rs274 reads it (inches).
        let offsets = acc_nc::parse_work_offsets_var("offsets.var", &text, Units::Inch)
            .expect("var file parses");
        let setup = Setup {
            work_offsets_mm: offsets,
            ..setup.clone()
        };
        std::fs::write(&var, text).expect("var file");
        let out = Command::new(&rs274)
            .env("HOME", tmp.path())
            .arg("-t")
            .arg(&tbl)
            .arg("-v")
            .arg(&var)
            .arg("-g")
            .arg(file)
            .output()
            .expect("run rs274");
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        let program = std::fs::read_to_string(file).expect("program");
        let mine = interpret(&name, &program, &setup);
        match (out.status.success(), mine) {
            (true, Ok(p)) => {
                let m = ours(&p.calls);
                match compare(&name, &parse_rs274(&stdout), &m) {
                    Ok(()) => agreed.push((name, m.0.len())),
                    Err(e) => failures.push(e),
                }
            }
            (true, Err(e)) => match REFUSED.iter().find(|r| r.0 == name) {
                Some((_, word)) if e.word == *word => refused.push((name, e.to_string())),
                _ => failures.push(format!("{name}: rs274 accepts, we refuse: {e}")),
            },
            (false, Ok(_)) => failures.push(format!(
                "{name}: rs274 refuses ({}), we accept",
                String::from_utf8_lossy(&out.stderr).trim()
            )),
            (false, Err(e)) => failures.push(format!("{name}: both refuse: {e}")),
        }
    }
    println!("program | motions | result");
    for (n, k) in &agreed {
        println!("{n} | {k} | agree");
    }
    for (n, e) in &refused {
        println!("{n} | - | refused by name: {e}");
    }
    println!(
        "{} programs agree with rs274, {} refused by name",
        agreed.len(),
        refused.len()
    );
    assert!(
        failures.is_empty(),
        "disagreements:\n{}",
        failures.join("\n")
    );
    assert!(agreed.len() >= 20, "only {} programs agree", agreed.len());
}

/// Bad programs (`tests/nc/bad/`): rs274 refuses each, we refuse each, at the same line
/// (rs274 echoes the offending block as its last line on stderr).
#[test]
fn rs274_and_acc_nc_refuse_the_same_bad_programs_at_the_same_line() {
    let Some(rs274) = rs274() else {
        skip_or_fail("rs274 (Debian linuxcnc-uspace) is not on PATH; install with .ci/deps");
        return;
    };
    let dir = repo_root().join("tests/nc/bad");
    let tmp = tempfile::tempdir().expect("temp dir");
    let files = programs(&dir);
    assert!(
        files.len() >= 10,
        "tests/nc/bad has {} programs",
        files.len()
    );
    let mut failures = Vec::new();
    for file in &files {
        let name = file
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        let text = std::fs::read_to_string(file).expect("program");
        let out = Command::new(&rs274)
            .env("HOME", tmp.path())
            .current_dir(tmp.path())
            .arg("-g")
            .arg(file)
            .output()
            .expect("run rs274");
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        let block = stderr
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("");
        match interpret(&name, &text, &Setup::default()) {
            Ok(_) => failures.push(format!("{name}: we accept, rs274 says {stderr:?}")),
            Err(_) if out.status.success() => failures.push(format!("{name}: rs274 accepts")),
            Err(e) => {
                let ours = text.lines().nth(e.span.line as usize - 1).unwrap_or("");
                println!(
                    "{e}\n    rs274: {}",
                    stderr.lines().nth(1).unwrap_or("").trim()
                );
                if ours.trim() != block.trim() {
                    failures.push(format!("{name}: we stop at {ours:?}, rs274 at {block:?}"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A small deterministic generator (xorshift64*), so that every run sees the same programs.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// A random program: units, distance modes, rapids, lines, arcs by I/J and by R (both
/// signs, both directions, helical), canned cycles G81/G82/G83 with G98/G99, feeds, N
/// numbers; positions tracked so arcs are valid.
fn random_program(seed: u64) -> String {
    let mut g = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let inch = g.next() < 0.3;
    let s = if inch { 1.0 / 25.4 } else { 1.0 };
    let mut out = format!(
        "{} G17 G90 G94\nS3000 M3\nF{:.3}\n",
        if inch { "G20" } else { "G21" },
        500.0 * s
    );
    let mut pos = [0.0_f64; 3];
    let mut incremental = false;
    for k in 0..60 {
        if g.next() < 0.1 {
            incremental = !incremental;
            out += if incremental { "G91\n" } else { "G90\n" };
        }
        let n = if g.next() < 0.3 {
            format!("N{} ", 10 * k)
        } else {
            String::new()
        };
        if g.next() < 0.08 {
            // A short series of canned cycles in G90, then a known position again.
            let code = ["G81", "G82", "G83"][(g.next() * 3.0) as usize % 3];
            let retract = if g.next() < 0.5 { "G98" } else { "G99" };
            let r = pos[2] + g.range(-2.0, 3.0) * s;
            let bottom = r - g.range(0.5, 8.0) * s;
            let extra = match code {
                "G82" => format!(" P{:.2}", g.range(0.0, 1.0)),
                "G83" => format!(" Q{:.4}", g.range(0.3, 3.0) * s),
                _ => String::new(),
            };
            out += &format!(
                "G90 {retract} {code} X{:.6} Y{:.6} Z{bottom:.6} R{r:.6}{extra}\n",
                pos[0] + g.range(-10.0, 10.0) * s,
                pos[1] + g.range(-10.0, 10.0) * s
            );
            out += &format!("{n}X{:.6}\nG80\n", pos[0] + g.range(-10.0, 10.0) * s);
            pos = [
                g.range(-20.0, 20.0) * s,
                g.range(-20.0, 20.0) * s,
                g.range(0.0, 5.0) * s,
            ];
            out += &format!("G0 X{:.6} Y{:.6} Z{:.6}\n", pos[0], pos[1], pos[2]);
            if incremental {
                out += "G91\n";
            }
            for v in &mut pos {
                *v = (*v * 1e6).round() / 1e6;
            }
            continue;
        }
        let choice = g.next();
        let z = pos[2] + g.range(-1.0, 1.0) * s;
        let word = |v: f64, p: f64, incremental: bool| if incremental { v - p } else { v };
        if choice < 0.5 {
            let to = [
                pos[0] + g.range(-20.0, 20.0) * s,
                pos[1] + g.range(-20.0, 20.0) * s,
                z,
            ];
            let code = if choice < 0.15 { "G0" } else { "G1" };
            let f = if g.next() < 0.2 {
                format!(" F{:.2}", g.range(50.0, 900.0) * s)
            } else {
                String::new()
            };
            out += &format!(
                "{n}{code} X{:.6} Y{:.6} Z{:.6}{f}\n",
                word(to[0], pos[0], incremental),
                word(to[1], pos[1], incremental),
                word(to[2], pos[2], incremental)
            );
            pos = to;
        } else {
            let code = if g.next() < 0.5 { "G2" } else { "G3" };
            let r = g.range(2.0, 15.0) * s;
            let a0 = g.range(0.0, std::f64::consts::TAU);
            let c = [pos[0] - r * a0.cos(), pos[1] - r * a0.sin()];
            let a1 = g.range(0.0, std::f64::consts::TAU);
            let to = [c[0] + r * a1.cos(), c[1] + r * a1.sin(), z];
            if choice < 0.75 {
                out += &format!(
                    "{n}{code} X{:.6} Y{:.6} Z{:.6} I{:.6} J{:.6}\n",
                    word(to[0], pos[0], incremental),
                    word(to[1], pos[1], incremental),
                    word(to[2], pos[2], incremental),
                    c[0] - pos[0],
                    c[1] - pos[1]
                );
            } else {
                let sign = if g.next() < 0.5 { -1.0 } else { 1.0 };
                out += &format!(
                    "{n}{code} X{:.6} Y{:.6} Z{:.6} R{:.6}\n",
                    word(to[0], pos[0], incremental),
                    word(to[1], pos[1], incremental),
                    word(to[2], pos[2], incremental),
                    sign * r * 1.01
                );
            }
            pos = to;
        }
        // Re-read the position as rs274 does: from the 6-decimal text.
        for v in &mut pos {
            *v = (*v * 1e6).round() / 1e6;
        }
    }
    out + "M2\n"
}

/// 100 random programs: rs274 and we agree on every motion of each.
#[test]
fn rs274_and_acc_nc_agree_on_random_programs() {
    let Some(rs274) = rs274() else {
        skip_or_fail("rs274 (Debian linuxcnc-uspace) is not on PATH; install with .ci/deps");
        return;
    };
    let tmp = tempfile::tempdir().expect("temp dir");
    let mut failures = Vec::new();
    let mut motions = 0;
    for seed in 0..100 {
        let text = random_program(seed);
        let file = tmp.path().join(format!("random_{seed}.ngc"));
        std::fs::write(&file, &text).expect("write");
        let out = Command::new(&rs274)
            .env("HOME", tmp.path())
            .current_dir(tmp.path())
            .arg("-g")
            .arg(&file)
            .output()
            .expect("run rs274");
        let name = format!("random_{seed}.ngc");
        match (
            out.status.success(),
            interpret(&name, &text, &Setup::default()),
        ) {
            (true, Ok(p)) => {
                let m = ours(&p.calls);
                motions += m.0.len();
                if let Err(e) = compare(
                    &name,
                    &parse_rs274(&String::from_utf8_lossy(&out.stdout)),
                    &m,
                ) {
                    failures.push(e);
                }
            }
            (a, b) => failures.push(format!(
                "{name}: rs274 ok {a}, ours {:?}; rs274 stderr {}",
                b.err(),
                String::from_utf8_lossy(&out.stderr).trim()
            )),
        }
    }
    println!("100 random programs, {motions} motions agree with rs274");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
