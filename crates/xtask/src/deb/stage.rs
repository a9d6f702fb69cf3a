//! What the package holds, staged under its root: the binary, the configuration tree, the
//! example programs and the docs. Modes are set here (0755 for the binary and for files
//! that are executable in the repository, 0644 for the others); `dpkg-deb
//! --root-owner-group` makes every entry root's.

use std::os::unix::fs::PermissionsExt as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context};

/// Where the binary goes.
pub const BIN: &str = "usr/bin/acc";

/// Folders of the repository copied whole: (source, destination under the package root).
/// `configs/` is the tree the binary embeds; its `linuxcnc/` is the example LinuxCNC
/// configuration (`/usr/share/acc/linuxcnc/`), and `ACC_CONFIGS=/usr/share/acc` makes
/// `acc` read these files instead of its embedded copy.
const TREES: [(&str, &str); 2] = [
    ("configs", "usr/share/acc"),
    ("docs", "usr/share/doc/acc/docs"),
];

/// Single files: (source, destination). The example programs are `acc linuxcnc`'s and the
/// LinuxCNC fault matrix's (`m52.ngc` and `linuxcnc_tool_change.ngc` are the rows' own,
/// found beside `--linuxcnc-program`).
const FILES: [(&str, &str); 5] = [
    ("README.md", "usr/share/doc/acc/README.md"),
    (
        "tests/nc/linuxcnc_short.ngc",
        "usr/share/acc/examples/linuxcnc_short.ngc",
    ),
    (
        "tests/nc/linuxcnc_accel.ngc",
        "usr/share/acc/examples/linuxcnc_accel.ngc",
    ),
    (
        "tests/nc/linuxcnc_tool_change.ngc",
        "usr/share/acc/examples/linuxcnc_tool_change.ngc",
    ),
    (
        "tests/nc/linuxcnc/m52.ngc",
        "usr/share/acc/examples/linuxcnc/m52.ngc",
    ),
];

/// Where the copyright file goes.
const COPYRIGHT: &str = "usr/share/doc/acc/copyright";

/// Stage the package's files from the repository `root` and the binary `bin` under `pkg`.
pub fn stage(root: &Path, bin: &Path, pkg: &Path) -> anyhow::Result<()> {
    for (src, dst) in TREES {
        let from = root.join(src);
        if !from.is_dir() {
            bail!("{}: no such folder in the repository", from.display());
        }
        copy_tree(&from, &pkg.join(dst))?;
    }
    for (src, dst) in FILES {
        copy_file(&root.join(src), &pkg.join(dst))?;
    }
    let copyright = super::copyright::text(env!("CARGO_PKG_LICENSE"))?;
    write_file(&pkg.join(COPYRIGHT), &copyright)?;
    install_binary(bin, &pkg.join(BIN))
}

/// `bin` to `dst`, stripped when `strip` is on the PATH (a debug build shrinks to a third),
/// mode 0755.
fn install_binary(bin: &Path, dst: &Path) -> anyhow::Result<()> {
    make_parent(dst)?;
    let stripped = Command::new("strip")
        .arg("-o")
        .arg(dst)
        .arg(bin)
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !stripped {
        eprintln!("xtask: no `strip`: {} shipped unstripped", bin.display());
        std::fs::copy(bin, dst).with_context(|| format!("copying {}", bin.display()))?;
    }
    set_mode(dst, 0o755)
}

/// The folder `from` copied to `to`, recursively.
fn copy_tree(from: &Path, to: &Path) -> anyhow::Result<()> {
    let entries = std::fs::read_dir(from).with_context(|| format!("{}", from.display()))?;
    for entry in entries {
        let entry = entry.with_context(|| format!("{}", from.display()))?;
        let path = entry.path();
        let target = to.join(entry.file_name());
        if path.is_dir() {
            copy_tree(&path, &target)?;
        } else {
            copy_file(&path, &target)?;
        }
    }
    Ok(())
}

/// One file copied, mode 0755 if it is executable in the repository, else 0644.
fn copy_file(from: &Path, to: &Path) -> anyhow::Result<()> {
    let meta = std::fs::metadata(from)
        .with_context(|| format!("{}: no such file in the repository", from.display()))?;
    make_parent(to)?;
    std::fs::copy(from, to).with_context(|| format!("copying {}", from.display()))?;
    let executable = meta.permissions().mode() & 0o111 != 0;
    set_mode(to, if executable { 0o755 } else { 0o644 })
}

/// `text` written to `to`, mode 0644.
fn write_file(to: &Path, text: &str) -> anyhow::Result<()> {
    make_parent(to)?;
    std::fs::write(to, text).with_context(|| format!("{}: cannot write it", to.display()))?;
    set_mode(to, 0o644)
}

/// `path`'s parent folders created, mode 0755.
fn make_parent(path: &Path) -> anyhow::Result<()> {
    let Some(dir) = path.parent() else {
        return Ok(());
    };
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create it", dir.display()))?;
    set_mode(dir, 0o755)
}

/// `path`'s permission bits set to `mode`.
fn set_mode(path: &Path, mode: u32) -> anyhow::Result<()> {
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
        .with_context(|| format!("{}: cannot set its mode", path.display()))
}

/// The files under `dir`, relative to it, sorted.
pub fn files(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).with_context(|| format!("{}", dir.display()))? {
        let path = entry.with_context(|| format!("{}", dir.display()))?.path();
        let name = PathBuf::from(path.file_name().unwrap_or_default());
        if path.is_dir() {
            found.extend(files(&path)?.into_iter().map(|p| name.join(p)));
        } else {
            found.push(name);
        }
    }
    found.sort();
    Ok(found)
}

/// The staged files' size as `Installed-Size` counts it: KiB, each file rounded up.
pub fn size_kib(dir: &Path) -> anyhow::Result<u64> {
    let mut kib = 0;
    for rel in files(dir)? {
        let path = dir.join(rel);
        let len = std::fs::metadata(&path)
            .with_context(|| format!("{}", path.display()))?
            .len();
        kib += len.div_ceil(1024);
    }
    Ok(kib)
}

/// `DEBIAN/md5sums` of the staged files (`dpkg --verify` checks an installation by it),
/// from `md5sum`.
pub fn write_md5sums(pkg: &Path) -> anyhow::Result<()> {
    let sums = super::stdout_of(
        Command::new("md5sum")
            .current_dir(pkg)
            .arg("--")
            .args(files(pkg)?),
        "Debian package coreutils",
    )?;
    let debian = pkg.join("DEBIAN");
    std::fs::create_dir_all(&debian).with_context(|| format!("{}", debian.display()))?;
    std::fs::write(debian.join("md5sums"), sums)
        .with_context(|| format!("{}: cannot write md5sums", debian.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stage_holds_every_file_with_its_mode() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let dir = tempfile::tempdir().expect("tmp");
        let bin = dir.path().join("acc-bin");
        std::fs::write(&bin, "#!/bin/sh\n").expect("bin");
        let pkg = dir.path().join("pkg");
        stage(&root, &bin, &pkg).expect("stage");
        let mode = |p: &str| {
            let m = std::fs::metadata(pkg.join(p)).unwrap_or_else(|e| panic!("{p}: {e}"));
            m.permissions().mode() & 0o777
        };
        assert_eq!(mode(BIN), 0o755);
        assert_eq!(mode("usr/share/acc/linuxcnc/ui.py"), 0o755);
        assert_eq!(mode("usr/share/acc/linuxcnc/acc.ini"), 0o644);
        assert_eq!(mode("usr/share/doc/acc/docs/linuxcnc.md"), 0o644);
        assert_eq!(mode("usr/share/acc/examples/linuxcnc/m52.ngc"), 0o644);
        assert_eq!(mode("usr/share/acc"), 0o755);
        let copyright = std::fs::read_to_string(pkg.join(COPYRIGHT)).expect("copyright");
        assert!(
            copyright.contains("License: MIT or Apache-2.0"),
            "{copyright}"
        );
        // The staged size counts every file: at least the docs' and configs' bytes.
        assert!(size_kib(&pkg).expect("size") > 300);
        write_md5sums(&pkg).expect("md5sums");
        let sums = std::fs::read_to_string(pkg.join("DEBIAN/md5sums")).expect("md5sums");
        assert_eq!(sums.lines().count(), files(&pkg).expect("files").len() - 1);
        assert!(
            sums.contains("  usr/share/acc/linuxcnc/acc.ini\n"),
            "{sums}"
        );
    }

    #[test]
    fn a_missing_source_file_is_named() {
        let dir = tempfile::tempdir().expect("tmp");
        let e =
            copy_file(&dir.path().join("README.md"), &dir.path().join("x")).expect_err("missing");
        assert!(e.to_string().contains("README.md: no such file"), "{e}");
    }
}
