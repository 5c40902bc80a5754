//! The cache of unpacked FMUs (`archive::cache`): a second unpacking of the same archive
//! takes the entry the first made, a changed archive gets an entry of its own, a corrupt
//! or hostile archive is refused with its error and leaves nothing in the cache nor
//! outside it, a cache folder others may write to is refused, and instances loaded
//! through the cache step as those of a temporary copy do.

mod common;

use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};

use common::{dist, entries, scratch, write_zip};
use inchworm_fmi_import::archive::{cache, Limits};
use inchworm_fmi_import::{CsFmu, ImportError, VarType};
use inchworm_fmu_models::{Dac, PlantFmu};

/// Everything in `dir`, sorted by name.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = match std::fs::read_dir(dir) {
        Ok(rd) => rd.map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect(),
        Err(_) => Vec::new(),
    };
    names.sort();
    names
}

/// The inode of the plant's library in an unpacked folder.
fn library_inode(dir: &Path) -> u64 {
    let lib = dir.join("binaries/linux64/InchwormPlant.so");
    std::fs::metadata(&lib).unwrap_or_else(|e| panic!("{}: {e}", lib.display())).ino()
}

#[test]
fn a_second_unpacking_takes_the_first_ones_entry() {
    let root = scratch("cache-reuse").join("cache");
    let fmu = dist("InchwormPlant.fmu");
    assert!(!cache::holds(&root, &fmu));
    let first = cache::unpack_cached(&fmu, &root, &Limits::DEFAULT).unwrap();
    assert!(first.is_cached());
    let entry = first.dir().to_path_buf();
    assert_eq!(entry.parent(), Some(root.as_path()));
    let name = entry.file_name().unwrap().to_string_lossy().into_owned();
    assert!(name.starts_with("v1-x86_64-linux-") && name.len() == 16 + 64, "{name}");
    assert_eq!(std::fs::metadata(&root).unwrap().mode() & 0o777, 0o700);
    let inode = library_inode(&entry);
    // In use by this process: a further unpacking gets a temporary copy of its own.
    assert!(!cache::holds(&root, &fmu));
    let private = cache::unpack_cached(&fmu, &root, &Limits::DEFAULT).unwrap();
    assert!(!private.is_cached());
    assert!(!private.dir().starts_with(&root));
    let private_dir = private.dir().to_path_buf();
    drop(private);
    assert!(!private_dir.exists(), "{} left behind", private_dir.display());
    drop(first);
    // Released: the next unpacking takes the same files, and nothing else is in the cache.
    assert!(entry.is_dir(), "the entry is kept after its last user");
    assert!(cache::holds(&root, &fmu));
    let second = cache::unpack_cached(&fmu, &root, &Limits::DEFAULT).unwrap();
    assert_eq!(second.dir(), entry);
    assert_eq!(library_inode(second.dir()), inode);
    assert_eq!(listing(&root), [name]);
    let _ = std::fs::remove_dir_all(root.parent().unwrap());
}

#[test]
fn a_changed_archive_gets_an_entry_of_its_own() {
    let dir = scratch("cache-changed");
    let root = dir.join("cache");
    let path = dir.join("plant.fmu");
    let mut e = entries(&dist("InchwormPlant.fmu"));
    write_zip(&path, &e);
    let before = cache::unpack_cached(&path, &root, &Limits::DEFAULT).unwrap();
    let before_dir = before.dir().to_path_buf();
    drop(before);
    // The same name, one byte more in a resource file.
    e.push(("resources/note.txt".into(), b"x".to_vec()));
    write_zip(&path, &e);
    assert!(!cache::holds(&root, &path));
    let after = cache::unpack_cached(&path, &root, &Limits::DEFAULT).unwrap();
    assert_ne!(after.dir(), before_dir);
    assert_eq!(std::fs::read(after.dir().join("resources/note.txt")).unwrap(), b"x");
    assert!(!before_dir.join("resources/note.txt").exists());
    assert_eq!(listing(&root).len(), 2, "{:?}", listing(&root));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn corrupt_and_hostile_archives_leave_nothing_behind() {
    let dir = scratch("cache-hostile");
    let root = dir.join("cache");
    let plant = entries(&dist("InchwormPlant.fmu"));
    let refused = |path: &Path, limits: &Limits| -> String {
        let e = cache::unpack_cached(path, &root, limits).unwrap_err();
        assert!(listing(&root).is_empty(), "{:?} left in the cache", listing(&root));
        e.to_string()
    };

    let garbage = dir.join("garbage.fmu");
    std::fs::write(&garbage, b"not a zip at all").unwrap();
    let e = refused(&garbage, &Limits::DEFAULT);
    assert!(e.starts_with("not an FMU: the file is not a zip archive"), "{e}");

    let truncated = dir.join("truncated.fmu");
    let whole = std::fs::read(dist("InchwormPlant.fmu")).unwrap();
    std::fs::write(&truncated, &whole[..whole.len() / 2]).unwrap();
    let e = refused(&truncated, &Limits::DEFAULT);
    assert!(e.starts_with("not an FMU: the file is not a zip archive"), "{e}");

    // A name climbing out, after the library has been written.
    let slip = dir.join("slip.fmu");
    let mut e = plant.clone();
    e.push(("resources/../../../escaped.txt".into(), b"out".to_vec()));
    write_zip(&slip, &e);
    let e = refused(&slip, &Limits::DEFAULT);
    assert_eq!(
        e,
        "the archive entry `resources/../../../escaped.txt` points outside the archive (absolute or `..` path): refused"
    );
    assert!(!dir.join("escaped.txt").exists() && !dir.join("../escaped.txt").exists());

    // A resource past the entry cap.
    let big = dir.join("big.fmu");
    let mut e = plant.clone();
    e.push(("resources/big.bin".into(), vec![0; 16 << 20]));
    write_zip(&big, &e);
    let small = Limits { entry_bytes: 8 << 20, ..Limits::DEFAULT };
    let e = refused(&big, &small);
    assert!(e.contains("resources/big.bin") && e.ends_with(": refused"), "{e}");

    // No modelDescription.xml.
    let bare = dir.join("bare.fmu");
    let e: Vec<_> = plant.into_iter().filter(|(n, _)| n != "modelDescription.xml").collect();
    write_zip(&bare, &e);
    assert_eq!(
        refused(&bare, &Limits::DEFAULT),
        "the archive has no modelDescription.xml at its root"
    );

    // Nothing was written beside the archives and the (empty) cache.
    assert_eq!(
        listing(&dir),
        ["bare.fmu", "big.fmu", "cache", "garbage.fmu", "slip.fmu", "truncated.fmu"]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_cache_others_may_write_to_is_refused() {
    let dir = scratch("cache-open");
    let root = dir.join("cache");
    std::fs::create_dir(&root).unwrap();
    std::fs::set_permissions(&root, std::fs::Permissions::from_mode(0o777)).unwrap();
    let e = cache::unpack_cached(&dist("InchwormPlant.fmu"), &root, &Limits::DEFAULT).unwrap_err();
    assert!(matches!(e, ImportError::Cache(_)), "{e:?}");
    assert_eq!(
        e.to_string(),
        format!(
            "the FMU cache {} belongs to another user or others may write to it (mode 777): refused (set INCHWORM_FMU_CACHE to a folder of your own, or to off)",
            root.display()
        )
    );
    assert!(listing(&root).is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The bits of the stack's extension after `steps` 2 ms steps of the plant at 10 V on the
/// extension DAC.
fn extension_after(fmu: &mut CsFmu, steps: usize) -> u64 {
    let dac = fmu.vrs_of(&[Dac::EXTENSION.name()], VarType::Real).unwrap();
    let ext = fmu.var_of(PlantFmu::EXTENSION.name(), VarType::Real).unwrap().vr;
    fmu.enter_initialization(None, 0.0, None).unwrap();
    fmu.exit_initialization().unwrap();
    fmu.set_real(&dac, &[10.0]).unwrap();
    for _ in 0..steps {
        fmu.do_step(0.002).unwrap();
    }
    let mut x = [0.0];
    fmu.get_real(&[ext], &mut x).unwrap();
    assert!(x[0] > 1e-6, "the stack extends at 10 V: {}", x[0]);
    x[0].to_bits()
}

#[test]
fn instances_load_from_the_cache_and_step_as_from_a_copy() {
    // The only test of this file that turns the cache on for the process: the others
    // call `unpack_cached` with a folder of their own.
    let root = scratch("cache-load").join("cache");
    let fmu = dist("InchwormPlant.fmu");
    let mut plain = CsFmu::load(&fmu, "plain", false).unwrap();
    let expected = extension_after(&mut plain, 50);
    cache::set_root(Some(root.clone()));
    let mut a = CsFmu::load(&fmu, "a", false).unwrap();
    let mut b = CsFmu::load(&fmu, "b", false).unwrap();
    cache::set_root(None);
    assert!(a.unpacked_dir().starts_with(&root), "{}", a.unpacked_dir().display());
    assert!(!b.unpacked_dir().starts_with(&root), "{}", b.unpacked_dir().display());
    assert_eq!(extension_after(&mut a, 50), expected);
    assert_eq!(extension_after(&mut b, 50), expected);
    let entry: PathBuf = a.unpacked_dir().to_path_buf();
    drop((a, b));
    assert!(entry.is_dir());
    let _ = std::fs::remove_dir_all(root.parent().unwrap());
}
