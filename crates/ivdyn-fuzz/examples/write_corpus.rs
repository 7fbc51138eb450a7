//! Writes the seeds of every fuzz target to `fuzz/corpus/<target>/seed-<i>` (the start of
//! cargo-fuzz's corpus; `make fuzz` runs this first).

fn main() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus");
    for t in ivdyn_fuzz::TARGETS {
        let dir = root.join(t);
        std::fs::create_dir_all(&dir).unwrap();
        for (i, s) in ivdyn_fuzz::seeds(t).iter().enumerate() {
            std::fs::write(dir.join(format!("seed-{i}")), s).unwrap();
        }
        println!("{}: {} seeds", dir.display(), ivdyn_fuzz::seeds(t).len());
    }
}
