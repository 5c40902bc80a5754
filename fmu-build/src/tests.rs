//! The build's own checks: the committed generated files against the tables, stale systems removed, the options.

use super::*;

/// A copy of the committed generated files in a scratch folder, as CI's clone has them.
fn committed_copy(files: &[(PathBuf, String)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let root = workspace_root();
    for (path, _) in files {
        let to = dir.path().join(path);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(root.join(path), &to)
            .unwrap_or_else(|e| panic!("{}: {e} (run fmu-build and commit it)", path.display()));
    }
    dir
}

#[test]
fn the_committed_files_are_what_the_tables_generate() {
    let files = committed_files(&fmus(), &systems());
    assert_eq!(check::drift(&workspace_root(), &files), Vec::<String>::new());
}

#[test]
fn every_model_s_declarations_hold_together() {
    for f in fmus() {
        assert_eq!((f.declarations)(), Ok(()));
    }
}

#[test]
fn an_edited_description_a_missing_set_and_a_stray_file_are_each_named() {
    let files = committed_files(&fmus(), &systems());
    let dir = committed_copy(&files);
    assert!(check::drift(dir.path(), &files).is_empty());

    let plant = dir.path().join("modelDescription/fmi3/InchwormPlant.xml");
    let text = std::fs::read_to_string(&plant).unwrap();
    let edited = text.replacen("causality=\"input\"", "causality=\"parameter\"", 1);
    assert_ne!(edited, text, "the plant has inputs to edit");
    std::fs::write(&plant, edited).unwrap();
    let set = dir.path().join("modelDescription/ssp/InchwormSystem/resources/plant.fia6.ssv");
    std::fs::remove_file(&set).unwrap();
    std::fs::write(dir.path().join("modelDescription/Old.xml"), "<x/>").unwrap();

    let found = check::drift(dir.path(), &files);
    assert_eq!(found.len(), 3, "{found:#?}");
    assert!(found[0].starts_with("modelDescription/fmi3/InchwormPlant.xml differs"), "{found:#?}");
    assert!(
        found[1].starts_with(
            "modelDescription/ssp/InchwormSystem/resources/plant.fia6.ssv cannot be read"
        ),
        "{found:#?}"
    );
    assert!(found[2].starts_with("modelDescription/Old.xml is not generated"), "{found:#?}");
}

#[test]
fn the_fmi3_open_loop_is_named_for_what_it_is() {
    let root = Path::new("/r");
    let at = |path: &str| {
        systems()
            .into_iter()
            .find(|s| system_path(root, s) == root.join(path))
            .unwrap_or_else(|| panic!("no system is written to {path}"))
    };
    let open = at("dist/fmi3/InchwormSystemOpen.ssp");
    assert_eq!((open.standard, open.spec.name), (Standard::Fmi3, "InchwormSystemOpen"));
    assert_eq!(open.fmi3, ["InchwormPlant", "InchwormController"]);
    assert_eq!(at("dist/fmi3/InchwormSystemMixed.ssp").spec.name, "InchwormSystem");
    let mut paths: Vec<_> = systems().iter().map(|s| system_path(root, s)).collect();
    let n = paths.len();
    paths.sort();
    paths.dedup();
    assert_eq!(paths.len(), n, "two systems share an archive: {paths:#?}");
}

#[test]
fn a_system_no_longer_built_is_removed_and_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let (dist, fmi3) = (dir.path().join("dist"), dir.path().join("dist/fmi3"));
    std::fs::create_dir_all(&fmi3).unwrap();
    let kept = [dist.join("InchwormSystemOpen.ssp"), fmi3.join("InchwormSystemOpen.ssp")];
    // The name the FMI 3.0 open loop had before it was named for what it is.
    let stale = fmi3.join("InchwormSystem.ssp");
    let other = [dist.join("InchwormPlant.fmu"), fmi3.join("InchwormPlant.fmu")];
    for p in kept.iter().chain([&stale]).chain(&other) {
        std::fs::write(p, "x").unwrap();
    }
    assert_eq!(remove_stale_systems(dir.path(), &kept), Ok(vec![stale.clone()]));
    assert!(!stale.exists());
    assert!(kept.iter().chain(&other).all(|p| p.exists()));
    assert_eq!(remove_stale_systems(dir.path(), &kept), Ok(vec![]));
    let empty = tempfile::tempdir().unwrap();
    assert_eq!(remove_stale_systems(empty.path(), &[]), Ok(vec![]));
}

#[test]
fn the_options_are_parsed_and_unknown_platforms_refused() {
    let a = |v: &[&str]| parse_args(&v.iter().map(|s| s.to_string()).collect::<Vec<_>>());
    let host = Selection::Host;
    assert_eq!(a(&[]), Ok(Args { check: false, root: None, prebuilt: None, platforms: host }));
    assert_eq!(
        a(&["--check"]),
        Ok(Args { check: true, root: None, prebuilt: None, platforms: Selection::Host })
    );
    assert_eq!(
        a(&["--platforms", "x86_64-linux,x86_64-windows", "--prebuilt", "bin"]),
        Ok(Args {
            check: false,
            root: None,
            prebuilt: Some("bin".into()),
            platforms: Selection::Listed(vec!["x86_64-linux".into(), "x86_64-windows".into()])
        })
    );
    assert!(a(&["--platforms", "x86_64-linux,sparc-solaris"])
        .unwrap_err()
        .contains("sparc-solaris"));
    assert!(a(&["--platforms"]).is_err());
    assert_eq!(a(&["--all-platforms"]).unwrap().platforms, Selection::All);
    assert_eq!(
        a(&["--all-platforms", "--prebuilt", "p"]).unwrap().prebuilt,
        Some(PathBuf::from("p"))
    );
    assert!(a(&["--prebuilt", "p"]).unwrap_err().contains("--all-platforms"));
    assert!(a(&["--all-platforms", "--platforms", "x86_64-linux"]).is_err());
    assert_eq!(a(&["--check", "--root", "/r"]).unwrap().root, Some(PathBuf::from("/r")));
    assert!(a(&["--root", "/r"]).unwrap_err().contains("--check only"));
    assert!(a(&["--fast"]).unwrap_err().contains("--fast"));
}

#[test]
fn every_generated_file_is_far_below_the_bound_of_the_check() {
    let files = committed_files(&fmus(), &systems());
    let (path, text) = files.iter().max_by_key(|(_, t)| t.len()).unwrap();
    assert!(
        text.len() as u64 <= check::MAX_FILE_BYTES / 8,
        "{} is {} bytes: raise check::MAX_FILE_BYTES to keep its margin",
        path.display(),
        text.len()
    );
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// An archive is written through a uniquely named temporary: a user's `<out>.partial` is
/// not the temporary (it stays), a failed write leaves nothing behind, and an output that
/// is a folder is refused before anything is written.
#[test]
fn an_archive_never_touches_a_user_s_partial_file_nor_leaves_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.ssp");
    let mine = dir.path().join("m.partial");
    std::fs::write(&mine, "the user's").unwrap();
    write_zip(&out, &[("SystemStructure.ssd".into(), b"<x/>".as_slice())]).unwrap();
    assert_eq!(std::fs::read_to_string(&mine).unwrap(), "the user's");
    assert_eq!(entries(dir.path()), ["m.partial", "m.ssp"]);
    // A folder in the way: refused by name, nothing written.
    let folder = dir.path().join("f.ssp");
    std::fs::create_dir(&folder).unwrap();
    let e = write_zip(&folder, &[("a".into(), b"1".as_slice())]).unwrap_err();
    assert!(e.contains("is a folder, not a file"), "{e}");
    assert_eq!(entries(dir.path()), ["f.ssp", "m.partial", "m.ssp"]);
    // Its folder missing: made, the archive written.
    let deep = dir.path().join("new").join("n.ssp");
    write_zip(&deep, &[("a".into(), b"1".as_slice())]).unwrap();
    assert_eq!(entries(&dir.path().join("new")), ["n.ssp"]);
}
