#!/usr/bin/env python3
"""Time ivdyn's dynamics kernels and Pinocchio's in the same run; print a ratio table.

Pinocchio is timed by the anchor harness in ../shared/anchors/pinocchio (build it first:
copy that folder somewhere writable and run its build.sh there; pass --anchor DIR).
ivdyn is timed by the criterion bench `benches/benches/dynamics.rs`. Runs are
interleaved (Pinocchio, ivdyn, Pinocchio, ivdyn, ...) on the same pinned core, and the
median of the per-run medians is reported.

The floor: Pinocchio's operation count of the same algorithm (the anchor's `flops`
tool, an instrumented scalar: multiplications + additions + divisions, sine and cosine
not included) at 4 scalar floating-point operations per cycle (two multiply and two add
pipes, no FMA in the default x86-64 target), at the effective clock the anchor's `calib`
measures in the same run. `x floor` = time / floor.

Usage: python benches/compare_pinocchio.py --anchor /tmp/anchor [--reps 2] [--core 1]
"""
import argparse
import csv
import io
import json
import os
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# (ivdyn group, pinocchio robot)
ROBOTS = [("ur5", "ur5"), ("paper", "dh6"), ("panda7", "panda7")]
# (ivdyn bench, pinocchio algo)
ALGOS = [("rnea", "rnea"), ("regressor", "regressor"), ("mass_matrix", "crba"),
         ("forward_dynamics", "aba"), ("gravity", "gravity")]


def run_pinocchio(anchor, core):
    exe = os.path.join(anchor, "build", "bench_native")
    out = subprocess.run(["taskset", "-c", str(core), exe, os.path.join(anchor, "build", "models"),
                          "--robots", ",".join(p for _, p in ROBOTS), "--batches", "4000", "--batch", "32"],
                         check=True, capture_output=True, text=True).stdout
    rows = [r for r in csv.reader(io.StringIO("\n".join(l for l in out.splitlines() if not l.startswith("#"))))]
    head = rows[0]
    res = {}
    for r in rows[1:]:
        d = dict(zip(head, r))
        res[(d["robot"], d["algo"])] = float(d["median_ns"])
    return res


def run_calib(anchor, core):
    out = subprocess.run(["taskset", "-c", str(core), os.path.join(anchor, "build", "calib")],
                         check=True, capture_output=True, text=True).stdout
    for line in out.splitlines():
        if line.startswith("calib effective_clock_GHz"):
            return float(line.split("median=")[1].split()[0])
    raise RuntimeError("calib printed no clock")


def run_flops(anchor):
    exe = os.path.join(anchor, "build", "flops")
    if os.path.exists(exe):
        out = subprocess.run([exe, os.path.join(anchor, "build", "models")],
                             check=True, capture_output=True, text=True).stdout
    else:  # the counts are deterministic: the anchor's stored run has them
        with open(os.path.join(anchor, "results", "flops.csv")) as f:
            out = f.read()
    rows = list(csv.reader(io.StringIO(out)))
    head = rows[0]
    return {(d["robot"], d["algo"]): int(d["flops(mul+add+div)"]) for d in (dict(zip(head, r)) for r in rows[1:])}


def run_ivdyn(core):
    subprocess.run(["taskset", "-c", str(core), "cargo", "bench", "-q", "-p", "ivdyn-benches", "--bench", "dynamics"],
                   check=True, cwd=ROOT, capture_output=True)
    res = {}
    for g, _ in ROBOTS:
        for a, _ in ALGOS:
            d = os.path.join(os.environ.get("CARGO_TARGET_DIR") or os.path.join(ROOT, "target"), "criterion", g, a)
            sub = [s for s in os.listdir(d) if s.isdigit()][0]
            with open(os.path.join(d, sub, "new", "estimates.json")) as f:
                res[(g, a)] = json.load(f)["median"]["point_estimate"]
    return res


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--anchor", required=True)
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--core", type=int, default=1)
    args = ap.parse_args()
    pin_runs, ivd_runs, clocks = [], [], []
    flops = run_flops(args.anchor)
    for r in range(args.reps):
        print(f"run {r + 1}/{args.reps}: pinocchio", file=sys.stderr)
        clocks.append(run_calib(args.anchor, args.core))
        pin_runs.append(run_pinocchio(args.anchor, args.core))
        print(f"run {r + 1}/{args.reps}: ivdyn", file=sys.stderr)
        ivd_runs.append(run_ivdyn(args.core))
    ghz = statistics.median(clocks)
    print("| robot | algorithm (ivdyn / Pinocchio) | ivdyn median ns | Pinocchio median ns | ratio ivdyn/Pinocchio"
          " | Pinocchio flops | floor ns | ivdyn x floor | Pinocchio x floor |")
    print("|---|---|--:|--:|--:|--:|--:|--:|--:|")
    for g, p in ROBOTS:
        for a, pa in ALGOS:
            iv = statistics.median(x[(g, a)] for x in ivd_runs)
            pv = statistics.median(x[(p, pa)] for x in pin_runs)
            fl = flops[(p, pa)]
            floor = fl / 4.0 / ghz
            print(f"| {g} | {a} / {pa} | {iv:.0f} | {pv:.0f} | {iv / pv:.2f} | {fl} | {floor:.0f} | {iv / floor:.1f}"
                  f" | {pv / floor:.1f} |")
    print(f"\neffective clock (calib, median of runs): {ghz:.2f} GHz; per run: {[round(c, 2) for c in clocks]}")
    for r, (pr, ir) in enumerate(zip(pin_runs, ivd_runs)):
        ratios = ", ".join(f"{g}/{a} {ir[(g, a)] / pr[(p, pa)]:.2f}" for g, p in ROBOTS for a, pa in ALGOS
                           if a in ("rnea", "mass_matrix"))
        print(f"run {r + 1} ratios: {ratios}")
    with open("/proc/loadavg") as f:
        print(f"\nloadavg after: {f.read().split()[:3]}; reps={args.reps}; core={args.core}")


if __name__ == "__main__":
    main()
