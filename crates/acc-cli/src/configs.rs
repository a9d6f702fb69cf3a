//! Where the command line finds a configuration file named by a bare name (`paper_case3`,
//! `case3`, `configs/calibration/seed000-sweep.toml`): one lookup for every subcommand.
//!
//! Order: the argument as a path (an existing file); `./configs/<kind>/<name>.toml`;
//! `$ACC_CONFIGS/<kind>/<name>.toml`; the copy of the repository's `configs/` tree that is
//! embedded in the `acc` binary, written once to a cache folder (so an installed `acc`
//! finds its shipped presets and scenarios, and the files they name relative to themselves).
//! Nothing here depends on where the binary was built.

use std::path::{Path, PathBuf};

use include_dir::{include_dir, Dir};

/// The repository's `configs/` tree, embedded at build time.
static SHIPPED: Dir<'static> = include_dir!("$CARGO_MANIFEST_DIR/../../configs");

/// Environment variable naming a configuration tree to search before the embedded one.
pub const ENV: &str = "ACC_CONFIGS";

/// The folder the embedded tree is written to (created on first use): the system's temp
/// folder, keyed by the `acc` version and the size of the tree.
fn cache_dir() -> PathBuf {
    fn size(d: &Dir<'_>) -> usize {
        d.files().map(|f| f.contents().len()).sum::<usize>() + d.dirs().map(size).sum::<usize>()
    }
    let bytes = size(&SHIPPED);
    std::env::temp_dir().join(format!("acc-configs-{}-{bytes}", env!("CARGO_PKG_VERSION")))
}

/// The embedded copy of `rel` (relative to `configs/`) on disk, if the binary ships it.
fn embedded(rel: &Path) -> Option<PathBuf> {
    SHIPPED.get_file(rel)?;
    let dir = cache_dir();
    let path = dir.join(rel);
    if !path.is_file() {
        std::fs::create_dir_all(&dir).ok()?;
        SHIPPED.extract(&dir).ok()?;
    }
    path.is_file().then_some(path)
}

/// Resolve `arg` for a file of `kind` (`scenarios`, `presets`, `calibration`, …): see the
/// module docs for the order. A name without an extension gets `.toml`. When nothing is
/// found the argument is returned as a path, so the loader's error names it.
pub fn find(kind: &str, arg: &str) -> PathBuf {
    let p = Path::new(arg);
    if p.is_file() {
        return p.to_path_buf();
    }
    let file = if p.extension().is_some() {
        PathBuf::from(arg)
    } else {
        PathBuf::from(format!("{arg}.toml"))
    };
    // `configs/<kind>/x.toml` given as a relative path from the repository root.
    let rel = match file.strip_prefix("configs") {
        Ok(r) => r.to_path_buf(),
        Err(_) if file.components().count() == 1 => Path::new(kind).join(&file),
        Err(_) => return p.to_path_buf(),
    };
    let local = Path::new("configs").join(&rel);
    if local.is_file() {
        return local;
    }
    if let Some(root) = std::env::var_os(ENV) {
        let q = Path::new(&root).join(&rel);
        if q.is_file() {
            return q;
        }
    }
    embedded(&rel).unwrap_or_else(|| p.to_path_buf())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bare_name_finds_the_shipped_file_from_any_folder() {
        // From a folder without configs/ (as an installed binary would run).
        let tmp = std::env::temp_dir();
        let scen = find("scenarios", "paper_case3");
        assert!(scen.is_file(), "{}", scen.display());
        let text = std::fs::read_to_string(&scen).expect("readable");
        assert!(text.contains("case3"), "{text}");
        // Files named relative to it are beside it (the whole tree is there).
        let preset = find("presets", "case3");
        assert!(preset.is_file(), "{}", preset.display());
        let cal = find("calibration", "configs/calibration/seed000-sweep.toml");
        assert!(cal.is_file(), "{}", cal.display());
        assert!(tmp.is_dir());
    }

    #[test]
    fn an_unknown_name_comes_back_as_given() {
        assert_eq!(
            find("scenarios", "no_such_scenario"),
            PathBuf::from("no_such_scenario")
        );
        assert_eq!(find("presets", "a/b.toml"), PathBuf::from("a/b.toml"));
    }

    #[test]
    fn the_embedded_tree_holds_the_shipped_files() {
        assert!(SHIPPED.get_file("scenarios/paper_case3.toml").is_some());
        assert!(SHIPPED.get_file("presets/case1.toml").is_some());
        let p = embedded(Path::new("presets/case1.toml")).expect("written");
        assert!(p.starts_with(std::env::temp_dir()));
        assert!(p.is_file());
    }
}
