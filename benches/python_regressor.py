#!/usr/bin/env python3
"""Stacked joint-torque regressors of the UR5 from Python: ivdyn vs Pinocchio, one run.

  (a)  ivdyn, batched: robot.regressor(q, qd, qdd, rigid_only=True) on (T, 6) arrays ->
       (T, 6, 60), multi-threaded in Rust with the GIL released;
  (a2) the same into a reused output array (``out=``): no allocation, no page faults;
  (a1) ivdyn, a Python loop of single-sample calls (per-call binding overhead);
  (b)  Pinocchio, a Python loop over pin.computeJointTorqueRegressor into a preallocated
       (T*6, 60) array (as ../shared/anchors/pinocchio/pipeline.py does);
  (c)  the same samples through ivdyn::batch::regressor_batch from Rust
       (crates/ivdyn-py/examples/regressor_timing.rs, `cargo run --release`), i.e. what
       the binding costs on top of the Rust call: (c) allocates a fresh output Vec per
       call as the binding does, (c') writes into one reused, already-touched buffer
       (no allocation, no page faults). Skipped if cargo is not found.

Same random samples for all (q uniform in the joint limits, qd, qdd uniform in [-1, 1]).
Times are the min and median of R repeats (the machine may be shared). Prints a table.

Usage (repo root, after `make py-test` or `pip install .` into .venv):
    .venv/bin/python benches/python_regressor.py [T] [--repeats R] [--no-rust]
"""
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np
import pinocchio as pin

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
URDF = os.path.join(ROOT, "fixtures", "ur5.urdf")
BASE, TIP = "base_link", "tool0"
VS_C = "vs (c')"


def timed(fn, repeats):
    ts, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t0)
    ts.sort()
    return ts[0], ts[len(ts) // 2], out


def rust_timing(q, qd, qdd, repeats):
    cargo = shutil.which("cargo")
    if cargo is None:
        return None, "cargo not found"
    manifest = os.path.join(ROOT, "Cargo.toml")
    build = [cargo, "build", "--release", "-q", "--manifest-path", manifest, "-p", "ivdyn-py",
             "--example", "regressor_timing"]
    r = subprocess.run(build, capture_output=True, text=True)
    if r.returncode != 0:
        return None, "cargo build failed: " + r.stderr.strip().splitlines()[-1]
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "samples.bin")
        np.concatenate([q.ravel(), qd.ravel(), qdd.ravel()]).astype("<f8").tofile(path)
        run = [cargo, "run", "--release", "-q", "--manifest-path", manifest, "-p", "ivdyn-py",
               "--example", "regressor_timing", "--", URDF, BASE, TIP, path, str(repeats)]
        r = subprocess.run(run, capture_output=True, text=True)
    if r.returncode != 0:
        return None, "regressor_timing failed: " + r.stderr.strip()
    line = [x for x in r.stdout.splitlines() if x.startswith("RUST_REGRESSOR")][0].split()
    return {"threads": int(line[3]), "min": float(line[4]), "median": float(line[5]),
            "checksum": float(line[6]), "reused_min": float(line[7]),
            "reused_median": float(line[8])}, None


def parse_args(argv):
    """`[T] [--repeats R] [--no-rust]` -> (T, R, no_rust)."""
    args = list(argv)
    repeats = 3
    if "--repeats" in args:
        i = args.index("--repeats")
        repeats = int(args[i + 1])
        del args[i:i + 2]
    no_rust = "--no-rust" in args
    args = [a for a in args if a != "--no-rust"]
    return (int(args[0]) if args else 100_000), repeats, no_rust


def pin_stack(model, data, q, qd, qdd):
    """The stacked regressor by a Python loop over Pinocchio, into a preallocated array."""
    t, n = q.shape
    y = np.empty((t * n, 10 * n))
    for k in range(t):
        y[k * n:(k + 1) * n] = pin.computeJointTorqueRegressor(model, data, q[k], qd[k], qdd[k])
    return y


def regressor_table(robot, model, data, q, qd, qdd, repeats, no_rust):
    """The regressor timings (ivdyn batched, into a buffer, per sample; Pinocchio; Rust);
    prints the table, returns (Y_pinocchio, relative difference, why Rust was skipped)."""
    t, n = q.shape
    # (a) ivdyn batched
    a_min, a_med, y_iv = timed(lambda: robot.regressor(q, qd, qdd, rigid_only=True), repeats)

    # (a2) ivdyn batched into a reused buffer (touched once before timing)
    buf = np.ones((t, n, 10 * n))
    o_min, o_med, y_out = timed(lambda: robot.regressor(q, qd, qdd, rigid_only=True, out=buf), repeats)
    assert y_out is buf and np.array_equal(buf, y_iv)

    # (b) Pinocchio loop into a preallocated array
    b_min, b_med, y_pin = timed(lambda: pin_stack(model, data, q, qd, qdd), repeats)
    err = np.abs(y_iv.reshape(t * n, 10 * n) - y_pin).max() / max(np.abs(y_pin).max(), 1.0)

    # (a1) ivdyn, one Python call per sample (fewer samples, scaled up)
    t1 = min(t, 20_000)

    def iv_loop():
        y = np.empty((t1 * n, 10 * n))
        for k in range(t1):
            y[k * n:(k + 1) * n] = robot.regressor(q[k], qd[k], qdd[k], rigid_only=True)
        return y

    l_min, l_med, _ = timed(iv_loop, repeats)
    l_min, l_med = l_min * t / t1, l_med * t / t1

    # (c) Rust, same samples
    rust, why = (None, "--no-rust") if no_rust else rust_timing(q, qd, qdd, max(repeats, 5))
    if rust is not None and not np.isclose(rust["checksum"], y_iv.sum(), rtol=1e-9):
        why, rust = f"checksum mismatch ({rust['checksum']} vs {y_iv.sum()})", None

    rows = [
        ("(a)  ivdyn Python, batched", a_min, a_med),
        ("(a2) ivdyn Python, batched, out= reused buffer", o_min, o_med),
        (f"(a1) ivdyn Python, per-sample loop{' (x' + str(t // t1) + ')' if t1 < t else ''}",
         l_min, l_med),
        ("(b)  Pinocchio Python loop", b_min, b_med),
    ]
    if rust is not None:
        rows.append((f"(c)  ivdyn Rust regressor_batch ({rust['threads']} threads)",
                     rust["min"], rust["median"]))
        rows.append(("(c') the same, into a reused buffer",
                     rust["reused_min"], rust["reused_median"]))
    print(f"max |Y_ivdyn - Y_pinocchio| / max|Y| = {err:.1e}")
    print()
    print(f"| {'method':<48} | {'min s':>8} | {'median s':>8} | {'us/sample':>9} | "
          f"{'vs (b)':>7} | {VS_C:>7} |")
    print(f"|{'-' * 50}|{'-' * 10}:|{'-' * 10}:|{'-' * 11}:|{'-' * 9}:|{'-' * 9}:|")
    for name, tmin, tmed in rows:
        vs_c = f"{tmin / rust['reused_min']:.2f}x" if rust is not None else "-"
        print(f"| {name:<48} | {tmin:8.4f} | {tmed:8.4f} | {1e6 * tmin / t:9.3f} | "
              f"{tmin / b_min:6.3f}x | {vs_c:>7} |")
    print()
    print("ratio = min time / min time of the reference row (lower is faster).")
    return y_pin, err, why


def speedup_table(title, ref, ours):
    """A two-row table: `ref` and `ours` as (name, min, median), speed-up against `ref`."""
    print()
    print(title)
    print(f"| {'method':<48} | {'min s':>8} | {'median s':>8} | {'speed-up':>8} |")
    print(f"|{'-' * 50}|{'-' * 10}:|{'-' * 10}:|{'-' * 10}:|")
    print(f"| {ref[0]:<48} | {ref[1]:8.4f} | {ref[2]:8.4f} | {'1.00x':>8} |")
    print(f"| {ours[0]:<48} | {ours[1]:8.4f} | {ours[2]:8.4f} | {ref[1] / ours[1]:7.2f}x |")


def rnea_table(robot, model, data, q, qd, qdd, repeats):
    """Inverse dynamics of the same samples: ivdyn batched vs a Python loop over pin.rnea
    (Pinocchio's model has no friction or armature, nor has the UR5 URDF: same torques)."""
    t, n = q.shape
    tau_buf = np.empty((t, n))
    r_min, r_med, tau_iv = timed(lambda: robot.rnea(q, qd, qdd, out=tau_buf), repeats)

    def pin_rnea():
        out = np.empty((t, n))
        for k in range(t):
            out[k] = pin.rnea(model, data, q[k], qd[k], qdd[k])
        return out

    p_min, p_med, tau_pin = timed(pin_rnea, repeats)
    rnea_err = np.abs(tau_iv - tau_pin).max() / np.abs(tau_pin).max()
    speedup_table(f"inverse dynamics, {t} samples (max rel. difference {rnea_err:.1e}):",
                  ("Pinocchio Python loop over pin.rnea", p_min, p_med),
                  ("ivdyn robot.rnea(Q, QD, QDD, out=)", r_min, r_med))


def fit_table(robot, model, data, q, qd, qdd, y_pin, rng, repeats):
    """Whole fit: regressor + least squares of the rigid-body parameters (Pinocchio: the
    loop above + numpy.linalg.lstsq, as ../shared/anchors/pinocchio/pipeline.py; ivdyn:
    base parameters + the fused multi-threaded fit, regressor never stored)."""
    t, n = q.shape
    theta = rng.uniform(-1.0, 1.0, 10 * n)
    tau = (y_pin @ theta).reshape(t, n) + 1e-3 * rng.standard_normal((t, n))

    def pin_fit():
        return np.linalg.lstsq(pin_stack(model, data, q, qd, qdd), tau.reshape(-1), rcond=None)[0]

    def iv_fit():
        base = ivdyn.base_params(robot, rigid_only=True)
        return ivdyn.fit_robot(robot, base, q, qd, qdd, tau), base

    f_min, f_med, th_pin = timed(pin_fit, repeats)
    g_min, g_med, (fit, base) = timed(iv_fit, repeats)
    fit_err = np.abs(fit.theta - base.project(th_pin)).max() / np.abs(base.project(th_pin)).max()
    speedup_table(f"whole fit, regressor + least squares ({t} samples, {base.base_count} rigid-body base parameters):",
                  ("Pinocchio loop + numpy.linalg.lstsq", f_min, f_med),
                  ("ivdyn.base_params + ivdyn.fit_robot", g_min, g_med))
    print(f"base estimates agree to {fit_err:.1e} (relative, max)")


def main():
    t, repeats, no_rust = parse_args(sys.argv[1:])
    robot = ivdyn.Robot.from_urdf(URDF, base=BASE, tip=TIP)
    model = pin.buildModelFromUrdf(URDF)
    data = model.createData()
    n = robot.dof
    assert model.nq == model.nv == n == 6, (model.nq, model.nv, n)
    rng = np.random.default_rng(0)
    q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit, size=(t, n))
    qd = rng.uniform(-1.0, 1.0, size=(t, n))
    qdd = rng.uniform(-1.0, 1.0, size=(t, n))

    with open("/proc/loadavg") as f:
        load = " ".join(f.read().split()[:3])
    print(f"UR5, T = {t} samples, regressor 6 x 60 each; ivdyn {ivdyn.__version__}, "
          f"pin {pin.__version__}, numpy {np.__version__}, {os.cpu_count()} CPUs, "
          f"ivdyn threads {ivdyn._ivdyn.batch_threads(t)}, loadavg {load}, R = {repeats}")
    y_pin, err, why = regressor_table(robot, model, data, q, qd, qdd, repeats, no_rust)
    rnea_table(robot, model, data, q, qd, qdd, repeats)
    if why is not None:
        print(f"(c) skipped: {why}")
    fit_table(robot, model, data, q, qd, qdd, y_pin, rng, repeats)
    if err > 1e-10:
        print("WARNING: ivdyn and Pinocchio regressors differ")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
