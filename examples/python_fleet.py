#!/usr/bin/env python3
"""A fleet on Ray, end to end (issue 18; docs/fleet.md): the synthetic fleet of
`ivdyn.fleet.synth` at the issue's example size (12 UR5 arms x 10 days, one 5-minute
500 Hz log a day: 120 logs, 10 log-hours), identified per arm and day on a local Ray
runtime, its drift tested against each arm's first day, what changed named by the
diagnosis (and the payload in kg), and the fleet report written.

    .venv/bin/python examples/python_fleet.py [OUT_DIR]       # OUT_DIR: default out/python_fleet
    .venv/bin/python examples/python_fleet.py out/small --arms 6 --days 5 --minutes 1 --rate 200

The fleet is generated once into OUT_DIR/fleet (kept for the next run: about 3 GB of MCAP
at the default size); the report goes to OUT_DIR/report. The three planted events
(arm-03's joint-3 friction rising 5 % a day from day 4, a 1.5 kg payload on arm-07 from
day 6, a 0.3 N m bias on arm-10's joint-2 torque from day 3) should be the changes
printed; benches/fleet_bench.py --synthetic times the same fleet.
"""
import argparse
import os
import time

from ivdyn import fleet
from ivdyn.fleet import synth

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
ap.add_argument("out", nargs="?", default=os.path.join(ROOT, "out", "python_fleet"))
ap.add_argument("--arms", type=int, default=12)
ap.add_argument("--days", type=int, default=10)
ap.add_argument("--minutes", type=float, default=5.0)
ap.add_argument("--rate", type=float, default=500.0)
ap.add_argument("--fdr", type=float, default=0.001)
ap.add_argument("--engine", choices=("ray", "local"), default="ray")
a = ap.parse_args()

where = os.path.join(a.out, "fleet")
if not os.path.exists(os.path.join(where, "fleet.csv")):
    t = time.perf_counter()
    f = synth.generate(where, os.path.join(ROOT, "fixtures", "ur5.urdf"), arms=a.arms, days=a.days,
                       minutes=a.minutes, rate=a.rate, seed=7, base="base_link", tip="wrist_3_link")
    print(f"generated {f.logs} logs in {time.perf_counter() - t:.0f} s")
manifest = os.path.join(where, "fleet.csv")

t = time.perf_counter()
res = fleet.run(manifest, engine=a.engine, progress=lambda k, n: print(f"\rlogs {k}/{n}", end="", flush=True))
print(f"\n{len(res.rows)} logs, {len(res.fits)} fits in {time.perf_counter() - t:.0f} s; failed: {len(res.failed)}")
tests = fleet.drift(res, q=a.fdr)
print(f"{len(tests)} drift tests, {sum(t['flagged'] for t in tests)} flagged at false-discovery rate {a.fdr:g}")
print("\nWhat changed (drift tests, the latest day against the first):")
for c in fleet.changes(tests):
    print("  " + c["words"])
named = fleet.diagnose(res, tests, engine=a.engine)
print("\nWhat the diagnosis names on the latest day, against the first day's model:")
for d in named:
    for w in d["words"]:
        print("  " + w)
for path in fleet.write_report(res, tests, report=os.path.join(a.out, "report"), fdr=a.fdr, diagnoses=named):
    print(f"written to {path}")
