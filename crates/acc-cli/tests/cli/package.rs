//! The Debian package of acc (`cargo run -p xtask -- deb`), built from this test build's
//! own `acc`: its control fields and contents checked, then installed. Under `CI` as root
//! it is installed with `dpkg -i` (`/usr/bin/acc`); elsewhere it is extracted with
//! `dpkg-deb -x` into `target/<profile>/deb-test/root` (a test does not change a
//! developer's system), and the test says so. The LinuxCNC tests (`linuxcnc.rs`) run the
//! installed binary on the installed example program, from a folder outside the
//! repository.
//!
//! Needs `dpkg-deb` and `dpkg-shlibdeps` (Debian packages dpkg, dpkg-dev): absent, the
//! tests print `SKIP: …` and pass, unless `CI` is set, then they fail.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The package, built and installed once per test process.
pub(crate) struct Installed {
    /// The `.deb`.
    pub deb: PathBuf,
    /// The root it is installed under: `/`, or the extraction folder.
    pub root: PathBuf,
}

impl Installed {
    /// The installed `acc` binary.
    pub fn acc(&self) -> PathBuf {
        self.root.join("usr/bin/acc")
    }

    /// An installed example NC program.
    pub fn example(&self, name: &str) -> PathBuf {
        self.root.join("usr/share/acc/examples").join(name)
    }
}

/// The repository's root (this crate is `crates/acc-cli`).
fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Why the package cannot be built here, or `None`.
fn missing_dpkg() -> Option<String> {
    ["/usr/bin/dpkg-deb", "/usr/bin/dpkg-shlibdeps"]
        .iter()
        .find(|f| !Path::new(f).exists())
        .map(|f| format!("{f} is not installed (apt-get install dpkg-dev)"))
}

/// The installed package, or `None` when `dpkg-deb` is missing on a developer machine
/// (`SKIP`; under `CI` it fails).
pub(crate) fn installed_or_skip() -> Option<&'static Installed> {
    if let Some(reason) = missing_dpkg() {
        if std::env::var_os("CI").is_some() {
            panic!("the package test is required under CI: {reason}");
        }
        eprintln!("SKIP: {reason}; the Debian package is not built");
        return None;
    }
    static PKG: OnceLock<Installed> = OnceLock::new();
    Some(PKG.get_or_init(build_and_install))
}

/// `cmd`'s stdout, after asserting that it succeeded.
fn run(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?}: {}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// `cargo run -p xtask -- deb` on this test build's `acc`, then the package installed.
fn build_and_install() -> Installed {
    let bin = PathBuf::from(env!("CARGO_BIN_EXE_acc"));
    let work = bin.parent().expect("target/<profile>").join("deb-test");
    let _ = std::fs::remove_dir_all(&work);
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let stdout = run(Command::new(cargo)
        .current_dir(repository())
        .args(["run", "--quiet", "-p", "xtask", "--", "deb", "--bin"])
        .arg(&bin)
        .arg("--out")
        .arg(&work)
        // The test build's binary is large (debug info stripped, 170 MB): packed as is.
        .args(["--compression", "none"]));
    let deb = PathBuf::from(stdout.trim());
    assert!(deb.is_file(), "xtask deb printed {stdout:?}");
    let as_root = run(Command::new("id").arg("-u")).trim() == "0";
    let root = if as_root && std::env::var_os("CI").is_some() {
        run(Command::new("dpkg").arg("-i").arg(&deb));
        eprintln!("installed {} with dpkg -i", deb.display());
        PathBuf::from("/")
    } else {
        let root = work.join("root");
        run(Command::new("dpkg-deb").arg("-x").arg(&deb).arg(&root));
        eprintln!(
            "NOTE: {} extracted into {} with dpkg-deb -x (dpkg -i only under CI as root)",
            deb.display(),
            root.display()
        );
        root
    };
    Installed { deb, root }
}

/// The files of the repository folder `dir`, relative to it.
fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).expect("read_dir") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            let sub = files_under(&path);
            let name = path.file_name().expect("name").to_owned();
            found.extend(sub.into_iter().map(|p| Path::new(&name).join(p)));
        } else {
            found.push(PathBuf::from(path.file_name().expect("name")));
        }
    }
    found
}

/// The control field `name` of `dpkg-deb --info`'s text.
fn field<'a>(info: &'a str, name: &str) -> &'a str {
    let prefix = format!(" {name}: ");
    info.lines()
        .find_map(|l| l.strip_prefix(&prefix))
        .unwrap_or_else(|| panic!("no {name} in\n{info}"))
}

#[test]
fn the_package_holds_the_binary_the_linuxcnc_configuration_and_the_docs() {
    let Some(pkg) = installed_or_skip() else {
        return;
    };
    let info = run(Command::new("dpkg-deb").arg("--info").arg(&pkg.deb));
    assert_eq!(field(&info, "Package"), "acc");
    assert_eq!(field(&info, "Version"), env!("CARGO_PKG_VERSION"));
    let arch = run(Command::new("dpkg").arg("--print-architecture"));
    assert_eq!(field(&info, "Architecture"), arch.trim());
    assert!(field(&info, "Depends").starts_with("libc6 (>= "), "{info}");
    assert_eq!(field(&info, "Recommends"), "linuxcnc-uspace");
    let size_kib: u64 = field(&info, "Installed-Size").parse().expect("a number");
    let bin_kib = std::fs::metadata(pkg.acc()).expect("acc installed").len() / 1024;
    assert!(size_kib > bin_kib, "Installed-Size {size_kib} KiB");

    let contents = run(Command::new("dpkg-deb").arg("--contents").arg(&pkg.deb));
    let entry = |path: &str| {
        contents
            .lines()
            .find(|l| l.ends_with(&format!(" ./{path}")))
            .unwrap_or_else(|| panic!("{path} not in the package:\n{contents}"))
    };
    for (path, mode) in [
        ("usr/bin/acc", "-rwxr-xr-x root/root"),
        ("usr/share/acc/linuxcnc/ui.py", "-rwxr-xr-x root/root"),
        ("usr/share/acc/linuxcnc/acc.ini", "-rw-r--r-- root/root"),
        ("usr/share/doc/acc/README.md", "-rw-r--r-- root/root"),
        ("usr/share/doc/acc/docs/linuxcnc.md", "-rw-r--r-- root/root"),
        ("usr/share/doc/acc/copyright", "-rw-r--r-- root/root"),
        (
            "usr/share/acc/examples/linuxcnc_short.ngc",
            "-rw-r--r-- root/root",
        ),
    ] {
        assert!(entry(path).starts_with(mode), "{}", entry(path));
    }
    // The configuration tree on disk is the repository's, which the binary embeds.
    let configs = repository().join("configs");
    for rel in files_under(&configs) {
        let installed = pkg.root.join("usr/share/acc").join(&rel);
        let shipped =
            std::fs::read(&installed).unwrap_or_else(|e| panic!("{}: {e}", installed.display()));
        assert!(
            shipped == std::fs::read(configs.join(&rel)).expect("repository file"),
            "{} differs from configs/{}",
            installed.display(),
            rel.display()
        );
    }
    // Every installed file is the packaged one (the package's md5sums, as `dpkg --verify`).
    let cwd = tempfile::tempdir().expect("temp dir");
    let control = cwd.path().join("control");
    run(Command::new("dpkg-deb")
        .arg("-e")
        .arg(&pkg.deb)
        .arg(&control));
    let sums = std::fs::read_to_string(control.join("md5sums")).expect("md5sums");
    assert!(sums.contains("  usr/bin/acc\n"), "{sums}");
    run(Command::new("md5sum")
        .current_dir(&pkg.root)
        .args(["--check", "--quiet"])
        .arg(control.join("md5sums")));
    // The installed binary runs from a folder outside the repository.
    let out = run(Command::new(pkg.acc())
        .current_dir(cwd.path())
        .arg("nc")
        .arg(pkg.example("linuxcnc_short.ngc")));
    assert!(
        out.lines()
            .any(|l| l.contains(" feed ") && l.contains("-3.0000")),
        "acc nc, the heavy slot's feed move:\n{out}"
    );
}
