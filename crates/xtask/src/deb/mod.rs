//! `cargo run -p xtask -- deb`: the Debian package of `acc`, `acc_<version>_<arch>.deb`.
//!
//! The package is staged as Debian's own tools stage one (`<out>/acc.build/debian/acc/`,
//! beside a minimal `debian/control`), then packed with `dpkg-deb --root-owner-group`.
//! What it holds is listed in [`stage`]; its control fields in [`control`].
//!
//! ```sh
//! cargo build --release -p acc-cli --features full
//! cargo run -p xtask -- deb                       # target/debian/acc_<version>_<arch>.deb
//! cargo run -p xtask -- deb --bin target/debug/acc --out /tmp/deb --compression none
//! ```

mod control;
mod copyright;
mod stage;

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context};

/// The options of `deb`.
#[derive(Debug, Clone, PartialEq)]
pub struct DebArgs {
    /// The `acc` binary to ship (`--bin`, default `target/release/acc`).
    pub bin: PathBuf,
    /// The folder the package is written to (`--out`, default `target/debian`).
    pub out: PathBuf,
    /// `Depends` stated by hand (`--depends`); `None`: computed by `dpkg-shlibdeps`.
    pub depends: Option<String>,
    /// `dpkg-deb -Z`: the archive's compression (`--compression`, default `gzip`, which
    /// every dpkg reads; `none` packs a debug build's binary in a second).
    pub compression: String,
}

/// The options `deb` takes, for its usage line.
const OPTIONS: &str = "--bin PATH, --out DIR, --depends TEXT, --compression TYPE";

/// The compressions `dpkg-deb -Z` takes.
const COMPRESSIONS: [&str; 4] = ["gzip", "xz", "zstd", "none"];

impl DebArgs {
    /// `args` (after `deb`) read; the defaults are relative to the repository `root`.
    pub fn parse(root: &Path, args: &[String]) -> anyhow::Result<Self> {
        let mut parsed = DebArgs {
            bin: root.join("target/release/acc"),
            out: root.join("target/debian"),
            depends: None,
            compression: "gzip".to_string(),
        };
        let mut it = args.iter();
        while let Some(option) = it.next() {
            let Some(value) = it.next() else {
                bail!("deb {option}: needs a value (options: {OPTIONS})");
            };
            match option.as_str() {
                "--bin" => parsed.bin = PathBuf::from(value),
                "--out" => parsed.out = PathBuf::from(value),
                "--depends" => parsed.depends = Some(value.clone()),
                "--compression" if COMPRESSIONS.contains(&value.as_str()) => {
                    parsed.compression = value.clone()
                }
                "--compression" => bail!(
                    "deb --compression {value}: allowed {}",
                    COMPRESSIONS.join(", ")
                ),
                _ => bail!("deb {option}: not an option; allowed: {OPTIONS}"),
            }
        }
        Ok(parsed)
    }
}

/// `deb`: the package built; its path printed.
pub fn run(root: &Path, args: &[String]) -> anyhow::Result<()> {
    let args = DebArgs::parse(root, args)?;
    let started = std::time::Instant::now();
    let deb = build(root, &args)?;
    let bytes = std::fs::metadata(&deb).map(|m| m.len()).unwrap_or(0);
    eprintln!(
        "xtask: {} ({:.1} MB) in {:.1} s",
        deb.display(),
        bytes as f64 / 1e6,
        started.elapsed().as_secs_f64()
    );
    println!("{}", deb.display());
    Ok(())
}

/// Stage and pack the package from the repository `root`: the `.deb`'s path.
pub fn build(root: &Path, args: &DebArgs) -> anyhow::Result<PathBuf> {
    if !args.bin.is_file() {
        bail!(
            "--bin {}: no such file (build it: cargo build --release -p acc-cli --features full)",
            args.bin.display()
        );
    }
    let arch = architecture()?;
    let version = env!("CARGO_PKG_VERSION");
    let scratch = args.out.join("acc.build");
    if scratch.exists() {
        std::fs::remove_dir_all(&scratch)
            .with_context(|| format!("{}: cannot remove it", scratch.display()))?;
    }
    let pkg = scratch.join("debian/acc");
    stage::stage(root, &args.bin, &pkg)?;
    let depends = match &args.depends {
        Some(d) => d.clone(),
        None => control::shlib_depends(&scratch, Path::new("debian/acc/usr/bin/acc"))?,
    };
    let fields = control::Control {
        version: version.to_string(),
        arch: arch.clone(),
        depends,
        installed_size_kib: stage::size_kib(&pkg)?,
        maintainer: control::maintainer(),
    };
    stage::write_md5sums(&pkg)?;
    let debian = pkg.join("DEBIAN");
    std::fs::write(debian.join("control"), fields.text())
        .with_context(|| format!("{}: cannot write control", debian.display()))?;
    let deb = args.out.join(format!("acc_{version}_{arch}.deb"));
    let status = Command::new("dpkg-deb")
        .args(["--root-owner-group", "--build"])
        .arg(format!("-Z{}", args.compression))
        .arg(&pkg)
        .arg(&deb)
        .stdout(std::process::Stdio::null())
        .status()
        .context("starting dpkg-deb (Debian package dpkg)")?;
    if !status.success() {
        bail!("dpkg-deb --build {}: {status}", pkg.display());
    }
    Ok(deb)
}

/// `dpkg --print-architecture`: the package's `Architecture`.
fn architecture() -> anyhow::Result<String> {
    let cmd = &mut Command::new("dpkg");
    let out = stdout_of(cmd.arg("--print-architecture"), "Debian package dpkg")?;
    Ok(String::from_utf8_lossy(&out).trim().to_string())
}

/// `cmd` run to its end: its stdout. An error names the command and, when it cannot
/// start, `what` it is (its Debian package, what to do instead); when it fails, its
/// status and stderr.
fn stdout_of(cmd: &mut Command, what: &str) -> anyhow::Result<Vec<u8>> {
    let out = cmd
        .output()
        .with_context(|| format!("starting {:?}: {what}", cmd.get_program()))?;
    if !out.status.success() {
        bail!(
            "{cmd:?}: {}: {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(out.stdout)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_are_read_and_a_bad_one_is_named() {
        let root = Path::new("/repo");
        let a = DebArgs::parse(root, &[]).expect("defaults");
        assert_eq!(a.bin, root.join("target/release/acc"));
        assert_eq!(a.out, root.join("target/debian"));
        let given: Vec<String> = ["--bin", "b/acc", "--depends", "libc6"]
            .map(String::from)
            .to_vec();
        let a = DebArgs::parse(root, &given).expect("given");
        assert_eq!(a.bin, PathBuf::from("b/acc"));
        assert_eq!(a.depends.as_deref(), Some("libc6"));
        let e = DebArgs::parse(root, &["--bn".into(), "x".into()]).expect_err("bad");
        assert!(e.to_string().contains("--bn: not an option"), "{e}");
        let e = DebArgs::parse(root, &["--compression".into(), "lz4".into()]).expect_err("lz4");
        assert!(
            e.to_string().contains("lz4: allowed gzip, xz, zstd, none"),
            "{e}"
        );
        let e = DebArgs::parse(root, &["--out".into()]).expect_err("no value");
        assert!(e.to_string().contains("--out: needs a value"), "{e}");
    }

    #[test]
    fn a_missing_binary_is_named() {
        let dir = tempfile::tempdir().expect("tmp");
        let args = DebArgs {
            bin: dir.path().join("no-acc"),
            out: dir.path().join("out"),
            depends: None,
            compression: "none".into(),
        };
        let e = build(dir.path(), &args).expect_err("no binary");
        assert!(e.to_string().contains("no-acc: no such file"), "{e}");
    }
}
