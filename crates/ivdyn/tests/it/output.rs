//! `output::OutputSet`: all or nothing, private staging, no symlink followed for a
//! temporary file, special files written in place.
#![cfg(unix)]

use crate::scratch::Scratch;
use std::os::unix::fs::{FileTypeExt, MetadataExt, PermissionsExt};
use std::path::Path;

use ivdyn::output::{OutputSet, write_json};

/// A fresh, empty directory for one test, removed when it passes.
fn tmpdir(name: &str) -> Scratch {
    Scratch::new(&format!("ivdyn_output_{name}"))
}

fn names(d: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

#[test]
fn staged_file_is_new_in_a_private_folder_beside_the_target() {
    let d = tmpdir("private");
    let mut set = OutputSet::new();
    let staged = set.stage(&d.join("x.json")).unwrap();
    let dir = staged.parent().unwrap();
    assert_eq!(std::fs::canonicalize(dir.parent().unwrap()).unwrap(), std::fs::canonicalize(&d).unwrap());
    assert!(dir.file_name().unwrap().to_string_lossy().starts_with(".ivdyn-"), "{}", dir.display());
    let m = std::fs::symlink_metadata(dir).unwrap();
    assert!(m.is_dir());
    assert_eq!(m.permissions().mode() & 0o777, 0o700, "staging folder must be private");
    assert_eq!(m.uid(), std::fs::metadata(&d).unwrap().uid());
    // the staged file exists, empty and regular, and is the folder's only entry
    let f = std::fs::symlink_metadata(&staged).unwrap();
    assert!(f.is_file() && f.len() == 0);
    assert_eq!(std::fs::read_dir(dir).unwrap().count(), 1);
    // a second set gets its own folder
    let mut other = OutputSet::new();
    let staged2 = other.stage(&d.join("x.json")).unwrap();
    assert_ne!(staged2.parent(), staged.parent());
    drop((set, other));
    assert!(names(&d).is_empty(), "left {:?}", names(&d));
}

#[test]
fn planted_symlinks_at_the_old_temporary_names_are_not_followed() {
    let d = tmpdir("planted");
    let victim = d.join("victim.txt");
    std::fs::write(&victim, "keep me").unwrap();
    // the names the old scheme used (`.x.json.<pid>.tmp`) and a guess at a staging folder
    let pid = std::process::id();
    for name in [format!(".x.json.{pid}.tmp"), ".ivdyn-x.json".into(), ".x.json.tmp".into()] {
        std::os::unix::fs::symlink(&victim, d.join(name)).unwrap();
    }
    write_json(&d.join("x.json"), &serde_json::json!({ "a": 1 })).unwrap();
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep me");
    let x = std::fs::symlink_metadata(d.join("x.json")).unwrap();
    assert!(x.file_type().is_file(), "x.json must be a new regular file");
    assert_eq!(names(&d).len(), 5, "only the planted links, the victim and x.json: {:?}", names(&d));
}

#[test]
fn nothing_is_written_until_commit_and_nothing_left_without_it() {
    let d = tmpdir("rollback");
    let old = d.join("old.json");
    std::fs::write(&old, "old").unwrap();
    let mut set = OutputSet::new();
    set.create_dir_all(&d.join("new/deeper")).unwrap();
    set.write_json(&d.join("new/deeper/a.json"), &1).unwrap();
    set.write_json(&old, &2).unwrap();
    set.write_bytes(&d.join("b.txt"), b"b").unwrap();
    assert_eq!(std::fs::read_to_string(&old).unwrap(), "old");
    assert!(!d.join("b.txt").exists());
    // a later output that cannot be written: a directory at the target
    std::fs::create_dir(d.join("c.json")).unwrap();
    assert!(set.write_json(&d.join("c.json"), &3).is_err());
    drop(set);
    assert_eq!(names(&d), ["c.json", "old.json"], "the created folders and staged files are removed");
    assert_eq!(std::fs::read_to_string(&old).unwrap(), "old");
}

#[test]
fn commit_puts_every_file_in_place_and_keeps_permissions() {
    let d = tmpdir("commit");
    let old = d.join("old.json");
    std::fs::write(&old, "old").unwrap();
    std::fs::set_permissions(&old, std::fs::Permissions::from_mode(0o600)).unwrap();
    let mut set = OutputSet::new();
    set.create_dir_all(&d.join("new")).unwrap();
    set.write_json(&d.join("new/a.json"), &1).unwrap();
    set.write_json(&old, &2).unwrap();
    set.commit().unwrap();
    assert_eq!(names(&d), ["new", "old.json"]);
    assert_eq!(names(&d.join("new")), ["a.json"]);
    assert_eq!(std::fs::read_to_string(&old).unwrap(), "2\n");
    assert_eq!(std::fs::metadata(&old).unwrap().permissions().mode() & 0o777, 0o600);
}

#[test]
fn a_symlink_target_is_written_through_and_stays_a_link() {
    let d = tmpdir("link");
    std::fs::create_dir(d.join("real")).unwrap();
    std::fs::write(d.join("real/p.json"), "old").unwrap();
    std::os::unix::fs::symlink("real/p.json", d.join("p.json")).unwrap();
    write_json(&d.join("p.json"), &[1, 2]).unwrap();
    assert!(std::fs::symlink_metadata(d.join("p.json")).unwrap().file_type().is_symlink());
    let v: Vec<i32> = serde_json::from_str(&std::fs::read_to_string(d.join("real/p.json")).unwrap()).unwrap();
    assert_eq!(v, [1, 2]);
    assert_eq!(names(&d), ["p.json", "real"]);
    assert_eq!(names(&d.join("real")), ["p.json"]);
}

#[test]
fn dev_null_stays_a_device() {
    write_json(Path::new("/dev/null"), &"x").unwrap();
    let m = std::fs::symlink_metadata("/dev/null").unwrap();
    assert!(m.file_type().is_char_device(), "/dev/null was replaced");
}

#[test]
fn a_fifo_gets_the_content_and_stays_a_fifo() {
    let d = tmpdir("fifo");
    let fifo = d.join("f");
    assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
    };
    write_json(&fifo, &serde_json::json!({ "k": [1, 2, 3] })).unwrap();
    let got: serde_json::Value = serde_json::from_str(&reader.join().unwrap()).unwrap();
    assert_eq!(got["k"][2], 3);
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
    assert_eq!(names(&d), ["f"]);
}

#[test]
fn a_writer_called_with_a_staged_path_writes_there_directly() {
    // write_csv and McapWriter stage their own file; given a path inside a live staging
    // folder they write it directly, so the outer set still commits everything at once
    let d = tmpdir("nested");
    let mut set = OutputSet::new();
    let target = d.join("t.json");
    set.write(&target, |p| write_json(p, &5)).unwrap();
    assert_eq!(names(&d).len(), 1, "only the staging folder: {:?}", names(&d));
    assert!(!target.exists());
    set.commit().unwrap();
    assert_eq!(names(&d), ["t.json"]);
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "5\n");
}
