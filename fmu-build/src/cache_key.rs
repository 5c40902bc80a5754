//! The key of the binary cache: the SHA-256 of everything that goes into a platform's
//! libraries (docs/platforms.md). Narrow on purpose, so a change elsewhere in the
//! workspace does not rebuild five platforms: of `Cargo.lock` only the entries of the
//! packages the libraries are built from, of the workspace manifest only what can change
//! how they build (not its member list, the dependencies of packages outside their tree,
//! the root package's tests and dev-dependencies, or comments), and every file of the
//! workspace packages in their tree.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

use sha2::{Digest, Sha256};

use crate::platforms::{path_with_venv, Linker, Output, Target, DEBIAN_RUSTC, RECIPE};

/// The SHA-256 of everything that goes into `outputs` for `target`, in hex.
pub fn cache_key(root: &Path, target: &Target, outputs: &[Output]) -> Result<String, String> {
    let mut h = Sha256::new();
    let mut put = |label: &str, bytes: &[u8]| {
        h.update((label.len() as u64).to_le_bytes());
        h.update(label.as_bytes());
        h.update((bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    };
    put("recipe", RECIPE.as_bytes());
    put("target", format!("{target:?} {}", target.cargo_target()).as_bytes());
    put("outputs", format!("{outputs:?}").as_bytes());
    let path = path_with_venv(root);
    let rustc = if target.build_std {
        DEBIAN_RUSTC.to_string()
    } else {
        std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into())
    };
    put("rustc", version(&rustc, &["-vV"], &path).as_bytes());
    put("cargo", version(&target.cargo(), &["-V"], &path).as_bytes());
    match target.linker {
        Linker::Host => put("linker", version("cc", &["--version"], &path).as_bytes()),
        Linker::Zig => {
            put("cargo-zigbuild", version("cargo-zigbuild", &["-V"], &path).as_bytes());
            put("zig", version("python-zig", &["version"], &path).as_bytes());
        }
        Linker::Gcc(gcc) => put("linker", version(gcc, &["--version"], &path).as_bytes()),
    }
    let tree = Tree::of(root, outputs)?;
    let read = |name: &str| {
        String::from_utf8_lossy(&std::fs::read(root.join(name)).unwrap_or_default()).into_owned()
    };
    put("Cargo.lock", lock_entries(&read("Cargo.lock"), &tree.packages).as_bytes());
    put("Cargo.toml", manifest_for_key(&read("Cargo.toml"), &tree.packages).as_bytes());
    put(".cargo/config.toml", read(".cargo/config.toml").as_bytes());
    let mut files = Vec::new();
    for dir in &tree.dirs {
        if dir == root {
            // The root package: its manifest (hashed above) and its sources.
            list(&root.join("src"), &mut files);
            list(&root.join("build.rs"), &mut files);
        } else {
            list(dir, &mut files);
        }
    }
    files.sort();
    files.dedup();
    for f in files {
        let rel = f.strip_prefix(root).unwrap_or(&f).to_string_lossy().into_owned();
        put(&rel, &std::fs::read(&f).map_err(|e| format!("{}: {e}", f.display()))?);
    }
    Ok(h.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// The first line of what `program args` prints, or why it could not run.
fn version(program: &str, args: &[&str], path: &std::ffi::OsStr) -> String {
    match Command::new(program).args(args).env("PATH", path).output() {
        Ok(o) => String::from_utf8_lossy(&o.stdout).trim().to_string(),
        Err(e) => format!("{program}: {e}"),
    }
}

/// Every file under `p` (or `p` itself), skipping build output and hidden folders.
fn list(p: &Path, out: &mut Vec<PathBuf>) {
    if p.is_file() {
        out.push(p.to_path_buf());
        return;
    }
    let Ok(entries) = std::fs::read_dir(p) else { return };
    for e in entries.filter_map(Result::ok) {
        let name = e.file_name();
        let name = name.to_string_lossy();
        if name.starts_with('.') || name == "target" {
            continue;
        }
        list(&e.path(), out);
    }
}

/// The packages `outputs` are built from, with all their dependencies (normal and build,
/// every target), as `cargo tree` lists them.
#[derive(Debug)]
struct Tree {
    /// Each package as `(name, version)`.
    packages: BTreeSet<(String, String)>,
    /// The folders of those inside the workspace.
    dirs: Vec<PathBuf>,
}

impl Tree {
    fn of(root: &Path, outputs: &[Output]) -> Result<Tree, String> {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.current_dir(root).args(["tree", "--prefix", "none", "-e", "normal,build", "--locked"]);
        cmd.args(["--target", "all"]);
        for o in outputs {
            let (Output::Library { package, .. } | Output::Binary { package, .. }) = o;
            cmd.args(["-p", package]);
        }
        let out = cmd.output().map_err(|e| format!("cannot run cargo tree: {e}"))?;
        if !out.status.success() {
            return Err(format!("cargo tree failed: {}", String::from_utf8_lossy(&out.stderr)));
        }
        Ok(Tree::parse(&String::from_utf8_lossy(&out.stdout), root))
    }

    /// `cargo tree --prefix none`'s lines: `name vX.Y.Z`, then ` (/path)` for a path
    /// package, ` (*)` for one listed before, ` (proc-macro)`.
    fn parse(text: &str, root: &Path) -> Tree {
        let mut packages = BTreeSet::new();
        let mut dirs = Vec::new();
        for l in text.lines() {
            let mut words = l.split_whitespace();
            if let (Some(name), Some(v)) = (words.next(), words.next()) {
                if let Some(v) = v.strip_prefix('v') {
                    packages.insert((name.to_string(), v.to_string()));
                }
            }
            if let Some(start) = l.find(" (/").map(|i| i + 2) {
                if let Some(len) = l[start..].find(')') {
                    let d = PathBuf::from(&l[start..start + len]);
                    if d.starts_with(root) {
                        dirs.push(d);
                    }
                }
            }
        }
        dirs.sort();
        dirs.dedup();
        Tree { packages, dirs }
    }
}

/// The `[[package]]` entries of `Cargo.lock` whose name and version are in `packages`:
/// what the lock fixes about the libraries' tree (versions, sources, checksums).
fn lock_entries(lock: &str, packages: &BTreeSet<(String, String)>) -> String {
    let field = |entry: &str, key: &str| {
        entry.lines().find_map(|l| {
            let v = l.strip_prefix(key)?.trim_start().strip_prefix('=')?.trim();
            Some(v.trim_matches('"').to_string())
        })
    };
    lock.split("[[package]]")
        .skip(1)
        .filter(|e| match (field(e, "name"), field(e, "version")) {
            (Some(n), Some(v)) => packages.contains(&(n, v)),
            _ => true,
        })
        .collect::<Vec<_>>()
        .join("[[package]]")
}

/// The workspace manifest without what cannot change how `packages` build: comments,
/// blank lines, the member list, `[workspace.dependencies]` of packages outside the tree,
/// and the root package's tests, benches, examples and dev-dependencies.
fn manifest_for_key(manifest: &str, packages: &BTreeSet<(String, String)>) -> String {
    let in_tree = |name: &str| packages.iter().any(|(n, _)| n == name);
    let (mut section, mut in_members) = (String::new(), false);
    let mut kept = String::new();
    for line in manifest.lines() {
        let t = line.trim();
        if in_members {
            in_members = !t.starts_with(']');
            continue;
        }
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        if t.starts_with('[') {
            section = t.to_string();
        }
        let skipped_section = ["[dev-dependencies]", "[[test]]", "[[bench]]", "[[example]]"];
        if skipped_section.contains(&section.as_str()) {
            continue;
        }
        if section == "[workspace]" && t.starts_with("members") {
            in_members = !t.ends_with(']');
            continue;
        }
        if section == "[workspace.dependencies]" && !t.starts_with('[') {
            let name = t.split(['=', '.', ' ']).next().unwrap_or_default();
            if !in_tree(name) {
                continue;
            }
        }
        kept.push_str(t);
        kept.push('\n');
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::platforms::targets;

    #[test]
    fn the_key_is_stable_and_covers_the_dependency_tree_only() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
        let t = targets()[0];
        let out = [Output::Library { package: "inchworm-plant-fmu", stem: "inchworm_plant_fmu" }];
        let a = cache_key(root, &t, &out).unwrap();
        assert_eq!(a, cache_key(root, &t, &out).unwrap());
        let tree = Tree::of(root, &out).unwrap();
        let dirs = &tree.dirs;
        assert!(tree.packages.iter().any(|(n, _)| n == "inchworm-plant"), "{tree:?}");
        assert!(!tree.packages.iter().any(|(n, _)| n == "clap"), "{tree:?}");
        assert!(dirs.contains(&root.join("crates/plant")), "{dirs:?}");
        assert!(!dirs.contains(&root.join("crates/bridge")), "{dirs:?}");
        let other = [Output::Library { package: "inchworm-mount-fmu", stem: "inchworm_mount_fmu" }];
        assert_ne!(a, cache_key(root, &t, &other).unwrap());
    }

    fn tree(list: &[(&str, &str)]) -> BTreeSet<(String, String)> {
        list.iter().map(|(n, v)| (n.to_string(), v.to_string())).collect()
    }

    #[test]
    fn the_lock_keeps_only_the_trees_entries() {
        let lock = "version = 4\n\n[[package]]\nname = \"a\"\nversion = \"1.0.0\"\n\n[[package]]\nname = \"b\"\nversion = \"2.0.0\"\ndependencies = [\n \"a\",\n]\n\n[[package]]\nname = \"a\"\nversion = \"0.9.0\"\n";
        let kept = lock_entries(lock, &tree(&[("a", "1.0.0")]));
        assert_eq!(kept, "\nname = \"a\"\nversion = \"1.0.0\"\n\n");
        let both = lock_entries(lock, &tree(&[("a", "1.0.0"), ("b", "2.0.0")]));
        assert!(both.contains("\"b\"") && !both.contains("0.9.0"), "{both}");
    }

    #[test]
    fn the_manifest_keeps_what_changes_a_build() {
        let m = "[package]\nname = \"root\"\n[dependencies]\na.workspace = true\n[dev-dependencies]\nx = \"1\"\n[[test]]\nname = \"t\"\n[workspace]\nmembers = [\n    \"crates/a\",\n]\nresolver = \"2\"\n[workspace.dependencies]\n# a comment\na = { path = \"crates/a\" }\nb = \"3\"\n[profile.release]\nopt-level = 3\n";
        let kept = manifest_for_key(m, &tree(&[("a", "0.1.0")]));
        let want = "[package]\nname = \"root\"\n[dependencies]\na.workspace = true\n[workspace]\nresolver = \"2\"\n[workspace.dependencies]\na = { path = \"crates/a\" }\n[profile.release]\nopt-level = 3\n";
        assert_eq!(kept, want);
        // A new member, an unrelated dependency, a test: the same key.
        let grown = m
            .replace("    \"crates/a\",\n", "    \"crates/a\",\n    \"crates/c\",\n")
            .replace("b = \"3\"", "b = \"4\"\nc = { path = \"crates/c\" }");
        assert_eq!(manifest_for_key(&grown, &tree(&[("a", "0.1.0")])), want);
        let one_line = m.replace("members = [\n    \"crates/a\",\n]", "members = [\"crates/a\"]");
        assert_eq!(manifest_for_key(&one_line, &tree(&[("a", "0.1.0")])), want);
    }
}
