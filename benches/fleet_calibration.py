"""Drift calibration of the fleet's per-log passes on the synthetic fleet (docs/fleet.md,
"Memory"): the p-values of the drift tests of the arms with no planted event, per pass.

    python benches/fleet_calibration.py stream memory positions
    python benches/fleet_calibration.py positions --exact-encoder

Passes: ``stream`` (the default, ``Options(stream=True)``: streamed, the log's velocity where
it agrees with the positions), ``memory`` (``Options(stream=False)``: read into memory, the
same velocity rule), ``positions`` (read into memory with the log's velocity dropped: the
positions differentiated, as the stream did before 2026-12-03).
``--exact-encoder``: the same fleet simulated without the encoder's quantisation. The
fleet (12 arms x 10 days of 1-minute 200 Hz logs, seed 7: the test's) is generated once
into ``--dir``. A calibrated test has 1 % of its p-values below 0.01 and 0.1 % below 0.001.
"""
from __future__ import annotations

import argparse
import os
import tempfile
from concurrent.futures import ThreadPoolExecutor

import numpy as np

import ivdyn
from ivdyn import _ivdyn, fleet
from ivdyn.fleet import synth

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def generate(d: str, exact: bool) -> str:
    manifest = os.path.join(d, "fleet.csv")
    if not os.path.exists(manifest):
        if exact:
            synth.SENSORS = dict(synth.SENSORS, encoder_bits=None)
        synth.generate(d, os.path.join(ROOT, "fixtures", "ur5.urdf"), arms=12, days=10, minutes=1, rate=200,
                       seed=7, base="base_link", tip="wrist_3_link")
    return manifest


def stats(e: fleet.LogEntry, how: str) -> bytes:
    if how != "positions":
        return fleet.log_stats(e, fleet.Options(stream=how == "stream"))
    robot = fleet._robot(e.model, e.base, e.tip)
    log = ivdyn.read_joint_states(e.log, robot)
    # the log without its velocity: prepared in memory, the positions differentiated
    return _ivdyn.fleet_log_stats(robot, {"t": log["t"], "q": log["q"], "tau": log["tau"]}, e.log,
                                  friction=["coulomb", "viscous"])


def run(manifest: str, how: str):
    entries = fleet.read_manifest(manifest)
    with ThreadPoolExecutor(os.cpu_count()) as ex:
        parts = list(ex.map(lambda e: stats(e, how), entries))
    groups: dict = {}
    for e, p in zip(entries, parts):
        groups.setdefault((e.robot, e.period), []).append((e, p))
    merged = {k: fleet.merge([p for _, p in v]) for k, v in groups.items()}
    fits = {k: fleet.fit(v[0][0].model, merged[k], base=v[0][0].base, tip=v[0][0].tip) for k, v in groups.items()}
    rows = [dict(log=e.log, robot=e.robot, period=e.period, payload=None, status="ok", error=None) for e in entries]
    return fleet.drift(fleet.FleetResult(rows=rows, stats=merged, fits=fits, entries=entries), q=0.001)


def summary(how: str, tests, changed) -> str:
    null = [t for t in tests if t["robot"] not in changed]
    p = np.array([t["p_value"] for t in null])
    share = {}
    for t in null:
        share.setdefault(t["effect"], []).append(t["p_value"] < 0.01)
    by = ", ".join(f"{k} {100 * np.mean(v):.1f} %" for k, v in sorted(share.items()))
    return (f"{how}: {len(p)} tests of unchanged arms; smallest p {p.min():.2g}; below 0.01: {100 * np.mean(p < 0.01):.1f} %, "
            f"below 0.001: {100 * np.mean(p < 0.001):.2f} %; false flags {sum(t['flagged'] for t in null)}\n"
            f"    below 0.01 per effect: {by}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("passes", nargs="+", choices=("memory", "positions", "stream"))
    ap.add_argument("--exact-encoder", action="store_true", help="simulate the fleet without encoder quantisation")
    ap.add_argument("--dir", help="where the fleet is generated (kept; default: under the temporary directory)")
    a = ap.parse_args()
    d = a.dir or os.path.join(tempfile.gettempdir(), "ivdyn-fleet-calib" + ("-exact" if a.exact_encoder else ""))
    manifest = generate(d, a.exact_encoder)
    changed = {e.robot for e in synth.events(12, 10, ["j1", "j2", "j3"], synth._dt.date(2026, 11, 1))}
    for how in a.passes:
        print(summary(how, run(manifest, how), changed))


if __name__ == "__main__":
    main()
