//! `DEBIAN/control`: the package's fields, and `Depends` computed from the binary's shared
//! libraries by Debian's own `dpkg-shlibdeps` (the libraries' packages at the versions
//! their symbols need).

use std::path::Path;
use std::process::Command;

use anyhow::Context;

/// The maintainer when `DEBFULLNAME` and `DEBEMAIL` are not set (the address matches the
/// workspace's placeholder repository).
const DEFAULT_MAINTAINER: &str = "acc developers <acc@example.invalid>";

/// The fields that differ between builds.
#[derive(Debug, Clone, PartialEq)]
pub struct Control {
    /// `Version`: the workspace's.
    pub version: String,
    /// `Architecture`: `dpkg --print-architecture`.
    pub arch: String,
    /// `Depends` (empty: no field).
    pub depends: String,
    /// `Installed-Size`, KiB.
    pub installed_size_kib: u64,
    /// `Maintainer`.
    pub maintainer: String,
}

impl Control {
    /// The control file's text.
    pub fn text(&self) -> String {
        let depends = if self.depends.is_empty() {
            String::new()
        } else {
            format!("Depends: {}\n", self.depends)
        };
        format!(
            "Package: acc\n\
             Version: {version}\n\
             Architecture: {arch}\n\
             Maintainer: {maintainer}\n\
             Installed-Size: {size}\n\
             {depends}\
             Recommends: linuxcnc-uspace\n\
             Section: misc\n\
             Priority: optional\n\
             Description: adaptive feedrate-override control for CNC milling\n \
             acc estimates the cutting force from the spindle's electrical power every\n \
             0.1 s and sets the feedrate override so that the force stays at its target.\n \
             On LinuxCNC it is the userspace HAL component `acc` (acc run --hal), which\n \
             drives motion.adaptive-feed; `acc linuxcnc` runs a program on headless\n \
             LinuxCNC with a simulated cutting process.\n \
             .\n \
             The package holds the acc binary, its configuration tree with the example\n \
             LinuxCNC configuration (/usr/share/acc/linuxcnc), example NC programs\n \
             (/usr/share/acc/examples) and the documentation (/usr/share/doc/acc).\n",
            version = self.version,
            arch = self.arch,
            maintainer = self.maintainer,
            size = self.installed_size_kib,
        )
    }
}

/// `DEBFULLNAME <DEBEMAIL>` (Debian's variables for a maintainer), else the default.
pub fn maintainer() -> String {
    match (std::env::var("DEBFULLNAME"), std::env::var("DEBEMAIL")) {
        (Ok(name), Ok(mail)) if !name.is_empty() && !mail.is_empty() => {
            format!("{name} <{mail}>")
        }
        _ => DEFAULT_MAINTAINER.to_string(),
    }
}

/// `Depends` of the binary at `bin` (relative to `scratch`, which gets the minimal
/// `debian/control` the tool reads), from `dpkg-shlibdeps -O`.
pub fn shlib_depends(scratch: &Path, bin: &Path) -> anyhow::Result<String> {
    let debian = scratch.join("debian");
    std::fs::create_dir_all(&debian).with_context(|| format!("{}", debian.display()))?;
    std::fs::write(
        debian.join("control"),
        "Source: acc\n\nPackage: acc\nArchitecture: any\n",
    )
    .with_context(|| format!("{}: cannot write control", debian.display()))?;
    let out = super::stdout_of(
        Command::new("dpkg-shlibdeps")
            .arg("-O")
            .arg(bin)
            .current_dir(scratch),
        "Debian package dpkg-dev, which computes Depends; install it or state Depends with --depends",
    )?;
    let stdout = String::from_utf8_lossy(&out);
    parse_shlibs(&stdout)
        .with_context(|| format!("dpkg-shlibdeps printed no shlibs:Depends: {stdout}"))
}

/// The value of `shlibs:Depends=…` in `dpkg-shlibdeps -O`'s output.
fn parse_shlibs(text: &str) -> Option<String> {
    text.lines()
        .find_map(|l| l.strip_prefix("shlibs:Depends="))
        .map(|v| v.trim().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_control_text_has_every_field_and_a_valid_description() {
        let c = Control {
            version: "0.1.0".into(),
            arch: "amd64".into(),
            depends: "libc6 (>= 2.35), libgcc-s1 (>= 4.2)".into(),
            installed_size_kib: 12_345,
            maintainer: "A <a@b.c>".into(),
        };
        let text = c.text();
        for field in [
            "Package: acc\n",
            "Version: 0.1.0\n",
            "Architecture: amd64\n",
            "Maintainer: A <a@b.c>\n",
            "Installed-Size: 12345\n",
            "Depends: libc6 (>= 2.35), libgcc-s1 (>= 4.2)\n",
            "Recommends: linuxcnc-uspace\n",
        ] {
            assert!(text.contains(field), "{field:?} in\n{text}");
        }
        // Every line after the synopsis is a continuation line (one leading space).
        let desc = text.split("Description: ").nth(1).expect("description");
        assert!(
            desc.lines()
                .skip(1)
                .all(|l| l.starts_with(' ') && l.len() > 1),
            "{desc}"
        );
        assert!(text.ends_with('\n'));
        let none = Control {
            depends: String::new(),
            ..c
        };
        assert!(!none.text().contains("Depends:"));
    }

    #[test]
    fn the_depends_line_is_read_from_dpkg_shlibdeps() {
        assert_eq!(
            parse_shlibs("shlibs:Depends=libc6 (>= 2.35), libgcc-s1 (>= 12)\n").as_deref(),
            Some("libc6 (>= 2.35), libgcc-s1 (>= 12)")
        );
        assert_eq!(parse_shlibs("misc:Depends=\n"), None);
    }
}
