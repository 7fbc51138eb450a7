//! The fuzz targets on mutated seeds for a few seconds each (stable; part of `make test`):
//! every input must return, not panic. `IVDYN_FUZZ_SECS` sets the seconds per target
//! (default 3); `make fuzz` runs the coverage-guided version (docs/reliability.md).
//! A panicking input is written to `target/fuzz-smoke-<target>.bin` to reproduce with
//! `ivdyn_fuzz::run`.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::time::{Duration, Instant};

use ivdyn_core::rng::Rng;
use ivdyn_fuzz::{TARGETS, mutate, remove_scratch, run, seeds};

fn budget() -> Duration {
    let s = std::env::var("IVDYN_FUZZ_SECS").ok().and_then(|v| v.parse::<f64>().ok()).unwrap_or(3.0);
    Duration::from_secs_f64(s)
}

fn smoke(target: &str) {
    let seeds = seeds(target);
    // the seeds themselves are valid input: they must read
    for s in &seeds {
        run(target, s);
    }
    let mut rng = Rng::new(0x1f0a ^ target.len() as u64);
    let (start, mut runs) = (Instant::now(), 0u64);
    // silence the default hook: a caught panic is reported below, with its input
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    while start.elapsed() < budget() {
        let k = (rng.next_u64() % seeds.len() as u64) as usize;
        let mut data = seeds[k].clone();
        let other = &seeds[(k + 1) % seeds.len()];
        for _ in 0..1 + rng.next_u64() % 8 {
            mutate(&mut rng, &mut data, other);
        }
        let t = Instant::now();
        let r = catch_unwind(AssertUnwindSafe(|| run(target, &data)));
        if let Err(p) = r {
            std::panic::set_hook(hook);
            let what = p.downcast_ref::<String>().cloned().or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()));
            let out =
                std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../target/fuzz-smoke-{target}.bin"));
            let _ = std::fs::write(&out, &data);
            panic!("{target}: input {runs} panicked ({what:?}); written to {}", out.display());
        }
        assert!(t.elapsed() < Duration::from_secs(20), "{target}: input {runs} took {:?}", t.elapsed());
        runs += 1;
    }
    std::panic::set_hook(hook);
    eprintln!("{target}: {runs} mutated inputs in {:.1} s, no panic", start.elapsed().as_secs_f64());
}

#[test]
fn targets_survive_mutated_seeds() {
    // one test, the targets in turn: the panic hook is process-wide
    for t in TARGETS {
        smoke(t);
    }
    remove_scratch();
}
