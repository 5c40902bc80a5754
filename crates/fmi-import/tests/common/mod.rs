//! Helpers shared by the integration tests: the project's packaged FMUs and rewritten
//! copies of them.
#![allow(dead_code)]

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

pub use inchworm_dist::path as dist;

/// A fresh directory for this test's files.
pub fn scratch(tag: &str) -> PathBuf {
    static N: AtomicU32 = AtomicU32::new(0);
    let d = std::env::temp_dir().join(format!(
        "inchworm-fmi-import-test-{}-{tag}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The entries of a zip archive: (name, bytes).
pub fn entries(path: &Path) -> Vec<(String, Vec<u8>)> {
    let mut z = zip::ZipArchive::new(std::fs::File::open(path).unwrap()).unwrap();
    (0..z.len())
        .map(|i| {
            let mut e = z.by_index(i).unwrap();
            let mut b = Vec::new();
            e.read_to_end(&mut b).unwrap();
            (e.name().to_owned(), b)
        })
        .collect()
}

/// Writes a zip archive of `entries` to `path`.
pub fn write_zip(path: &Path, entries: &[(String, Vec<u8>)]) {
    let mut w = zip::ZipWriter::new(std::fs::File::create(path).unwrap());
    for (name, bytes) in entries {
        w.start_file(name.as_str(), zip::write::SimpleFileOptions::default()).unwrap();
        w.write_all(bytes).unwrap();
    }
    w.finish().unwrap();
}

/// A copy of the plant FMU at `dir/name` with `modelDescription.xml` passed through `md`
/// and each other entry through `other` (`None` drops it).
pub fn plant_variant(
    dir: &Path,
    name: &str,
    md: impl Fn(&str) -> String,
    other: impl Fn(&str, Vec<u8>) -> Option<(String, Vec<u8>)>,
) -> PathBuf {
    let out = dir.join(name);
    let e: Vec<(String, Vec<u8>)> = entries(&dist("InchwormPlant.fmu"))
        .into_iter()
        .filter_map(|(n, b)| {
            if n == "modelDescription.xml" {
                Some((n, md(std::str::from_utf8(&b).unwrap()).into_bytes()))
            } else {
                other(&n, b)
            }
        })
        .collect();
    write_zip(&out, &e);
    out
}

/// Replaces the first occurrence of `from`, failing loudly if it is not there.
pub fn replace_once(s: &str, from: &str, to: &str) -> String {
    assert!(s.contains(from), "modelDescription.xml lacks `{from}`");
    s.replacen(from, to, 1)
}
