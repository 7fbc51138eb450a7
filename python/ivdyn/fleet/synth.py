"""A synthetic fleet for tests and the demo (issue 18, item 6): ``arms`` arms of one model,
each with its own manufacturing spread, one log a day for ``days`` days, and three planted
events, written as logs, a manifest and the truth::

    python -m ivdyn.fleet.synth --model fixtures/ur5.urdf --arms 12 --days 10 --minutes 1 \\
        --rate 200 --out fleet-demo

writes ``fleet-demo/logs/<arm>/<date>.mcap``, ``fleet-demo/fleet.csv`` (the manifest of
:func:`ivdyn.fleet.read_manifest`: one period per day, the date) and
``fleet-demo/truth.json`` (every arm's true drive parameters and inertial factors, and
the planted events). Seeded: the same arguments write the same files.

Each arm is the model with every link's inertials (mass, first and second moments
together: a density change, so the link stays physically consistent) scaled by a factor
in ``1 +- INERTIAL_SPREAD`` and each joint's Coulomb and viscous friction by factors in
``1 +- FRICTION_SPREAD`` (uniform). Each day's log is ``ivdyn.simulate`` (the one
simulation: exact inverse dynamics along a random Fourier excitation, its seed the arm's
and the day's) of the arm's model that day, with the sensors of :data:`SENSORS`: white
torque noise, a quantised torque and a quantised encoder.

The events (arms and days from the fleet's size, :func:`events`):

* ``friction_rise``: joint 3's Coulomb friction grows by ``FRICTION_RISE`` of its value
  per day from its onset day on (on the onset day by one step);
* ``payload``: from its day on, a payload of ``PAYLOAD_MASS`` kg on the last link;
* ``torque_bias``: from its day on, joint 2's torque sensor reads ``TORQUE_BIAS`` N m
  more than the joint's torque (a constant offset: the model's ``<joint>.tau0``).
"""
from __future__ import annotations

import argparse
import dataclasses
import datetime as _dt
import json
import os
import shutil
import sys
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from .._pipeline import simulate
from .. import _ivdyn

#: Manufacturing spread: inertials within +-5 %, friction within +-20 % (uniform).
INERTIAL_SPREAD = 0.05
FRICTION_SPREAD = 0.20
#: Nominal friction of the UR5's six joints (N m and N m s/rad; the messy-log generator's).
FC = (2.0, 2.0, 1.5, 0.6, 0.6, 0.4)
FV = (0.8, 0.8, 0.5, 0.2, 0.2, 0.1)
#: The events' sizes: joint 3's Coulomb friction +5 % of its value per day; a 1.5 kg
#: payload 5 cm along the last link's z axis; a 0.3 N m bias on joint 2's torque.
FRICTION_RISE = 0.05
PAYLOAD_MASS = 1.5
PAYLOAD_COM = (0.0, 0.0, 0.05)
TORQUE_BIAS = 0.3
#: Sensors: torque noise (N m, standard deviation), torque resolution (N m), encoder bits.
SENSORS = {"noise": 0.1, "tau_resolution": 0.01, "encoder_bits": 18}
#: Link parameters per link (the order of ``Robot.param_names``).
LINK_PARAMS = 10


@dataclasses.dataclass(frozen=True)
class Event:
    """A planted change: ``robot`` (arm id), ``kind`` (``friction_rise``, ``payload``,
    ``torque_bias``), the drift effect it is (``coulomb_friction``, ``payload``,
    ``torque_offset``) and joint (``None`` for the payload), the first ``day`` it is in
    the logs (index from 0) and that day's ``period`` (date), and its size."""
    robot: str
    kind: str
    effect: str
    joint: Optional[str]
    day: int
    period: str
    size: float
    unit: str


def arm_id(a: int) -> str:
    return f"arm-{a:02d}"


def period_of(start: _dt.date, day: int) -> str:
    return (start + _dt.timedelta(days=day)).isoformat()


def events(arms: int, days: int, joints: Sequence[str], start: _dt.date) -> List[Event]:
    """The three planted events of a fleet of ``arms`` arms over ``days`` days: on arms
    ``arms/4``, ``7 arms/12`` and ``5 arms/6`` (arm-03, -07, -10 of twelve), from days
    ``2 days/5``, ``3 days/5`` and ``3 days/10`` (days 4, 6 and 3 of ten)."""
    if arms < 3 or days < 3 or len(joints) < 3:
        raise ValueError(f"a synthetic fleet needs at least 3 arms, 3 days and 3 joints, got {arms} arms, "
                         f"{days} days, {len(joints)} joints")
    a = (arms // 4, (7 * arms) // 12, (5 * arms) // 6)
    d = (max(1, 2 * days // 5), max(1, 3 * days // 5), max(1, 3 * days // 10))
    return [
        Event(arm_id(a[0]), "friction_rise", "coulomb_friction", joints[2], d[0], period_of(start, d[0]),
              FRICTION_RISE, "of the value per day"),
        Event(arm_id(a[1]), "payload", "payload", None, d[1], period_of(start, d[1]), PAYLOAD_MASS, "kg"),
        Event(arm_id(a[2]), "torque_bias", "torque_offset", joints[1], d[2], period_of(start, d[2]),
              TORQUE_BIAS, "N m"),
    ]


def arm_spread(robot, rng: np.random.Generator) -> Dict[str, Any]:
    """One arm's manufacturing spread: a factor per link (inertials) and per joint
    (Coulomb, viscous friction)."""
    n = robot.dof
    return {
        "inertial_scale": rng.uniform(1 - INERTIAL_SPREAD, 1 + INERTIAL_SPREAD, n).tolist(),
        "fc_scale": rng.uniform(1 - FRICTION_SPREAD, 1 + FRICTION_SPREAD, n).tolist(),
        "fv_scale": rng.uniform(1 - FRICTION_SPREAD, 1 + FRICTION_SPREAD, n).tolist(),
    }


def arm_day_params(robot, spread: Dict[str, Any], planted: Sequence[Event], robot_id: str, day: int
                   ) -> Dict[str, Any]:
    """The parameter file of arm ``robot_id`` on ``day``: the model with the arm's spread,
    nominal friction (:data:`FC`, :data:`FV`) and the friction rise or torque bias planted
    on it (the payload is passed to the simulation)."""
    n = robot.dof
    names = list(robot.param_names)
    theta = np.array(robot.params, dtype=float)
    for j in range(n):
        theta[j * LINK_PARAMS:(j + 1) * LINK_PARAMS] *= spread["inertial_scale"][j]
    idx = {name: i for i, name in enumerate(names)}
    joints = list(robot.joint_names)
    for j, jn in enumerate(joints):
        theta[idx[f"{jn}.fc"]] = FC[j % len(FC)] * spread["fc_scale"][j]
        theta[idx[f"{jn}.fv"]] = FV[j % len(FV)] * spread["fv_scale"][j]
    for e in planted:
        if e.robot != robot_id or day < e.day:
            continue
        if e.kind == "friction_rise":
            theta[idx[f"{e.joint}.fc"]] *= 1.0 + e.size * (day - e.day + 1)
        elif e.kind == "torque_bias":
            theta[idx[f"{e.joint}.tau0"]] += e.size
    return {"robot": robot.name, "joints": joints, "names": names, "theta": theta.tolist()}


@dataclasses.dataclass(frozen=True)
class Fleet:
    """What :func:`generate` wrote: the manifest, the truth file, and the events."""
    manifest: str
    truth: str
    events: List[Event]
    logs: int


def generate(out: str, model: str, *, arms: int = 12, days: int = 10, minutes: float = 1.0,
             rate: float = 200.0, seed: int = 1, base: Optional[str] = None, tip: Optional[str] = None,
             start: str = "2026-11-01", workers: Optional[int] = None) -> Fleet:
    """Writes the synthetic fleet under ``out`` (module docstring); ``model`` is copied
    there, so the directory stands alone. ``base``/``tip`` choose the chain."""
    if minutes <= 0 or rate <= 0:
        raise ValueError(f"minutes and rate must be positive, got {minutes} and {rate}")
    robot = _ivdyn.Robot.from_urdf(model, base, tip, False)
    day0 = _dt.date.fromisoformat(start)
    planted = events(arms, days, robot.joint_names, day0)
    rng = np.random.default_rng(seed)
    spreads = {arm_id(a): arm_spread(robot, rng) for a in range(arms)}
    os.makedirs(out, exist_ok=True)
    urdf = os.path.basename(model)
    shutil.copyfile(model, os.path.join(out, urdf))
    jobs = [(a, d) for a in range(arms) for d in range(days)]

    def one(job):
        a, d = job
        rid, period = arm_id(a), period_of(day0, d)
        rel = os.path.join("logs", rid, f"{period}.mcap")
        os.makedirs(os.path.join(out, "logs", rid), exist_ok=True)
        pay = next((e for e in planted if e.kind == "payload" and e.robot == rid and d >= e.day), None)
        simulate(robot, os.path.join(out, rel), params=arm_day_params(robot, spreads[rid], planted, rid, d),
                 duration=60.0 * minutes, rate=rate, seed=seed * 100_003 + 1000 * a + d + 1,
                 payload_mass=None if pay is None else pay.size,
                 payload_com=None if pay is None else list(PAYLOAD_COM), **SENSORS)
        return f"{rel},{rid},{urdf},{period},{period}T09:00:00,,{robot.base_link},{robot.tip_link}\n"

    with ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1) as ex:
        rows = list(ex.map(one, jobs))
    manifest = os.path.join(out, "fleet.csv")
    _write_text(manifest, "log,robot,model,period,time,payload,base,tip\n" + "".join(rows))
    truth = os.path.join(out, "truth.json")
    doc = {"model": urdf, "base": robot.base_link, "tip": robot.tip_link, "arms": arms, "days": days,
           "start": start, "minutes": minutes, "rate": rate, "seed": seed, "sensors": SENSORS,
           "spread": spreads, "nominal": {"fc": FC[:robot.dof], "fv": FV[:robot.dof]},
           "events": [dataclasses.asdict(e) for e in planted]}
    _write_text(truth, json.dumps(doc, indent=1) + "\n")
    return Fleet(manifest=manifest, truth=truth, events=planted, logs=len(rows))


def _write_text(path: str, text: str) -> None:
    """Whole or not at all: a temporary file beside ``path``, then renamed."""
    tmp = f"{path}.tmp-{os.getpid()}"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def main(argv: Optional[List[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="python -m ivdyn.fleet.synth", description=__doc__.split("\n\n")[0])
    p.add_argument("--model", default=os.path.join("fixtures", "ur5.urdf"), help="URDF of every arm")
    p.add_argument("--base", help="base link of the chain")
    p.add_argument("--tip", help="tip link of the chain")
    p.add_argument("--arms", type=int, default=12)
    p.add_argument("--days", type=int, default=10)
    p.add_argument("--minutes", type=float, default=1.0, help="length of each daily log")
    p.add_argument("--rate", type=float, default=200.0, help="sample rate (Hz)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--start", default="2026-11-01", help="date of the first day")
    p.add_argument("--out", required=True, help="output directory")
    a = p.parse_args(argv)
    f = generate(a.out, a.model, arms=a.arms, days=a.days, minutes=a.minutes, rate=a.rate, seed=a.seed,
                 base=a.base, tip=a.tip, start=a.start)
    print(f"{f.logs} logs; manifest {f.manifest}; truth {f.truth}")
    for e in f.events:
        print(f"planted: {e.robot} {e.kind} ({e.effect}{', ' + e.joint if e.joint else ''}) from {e.period}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
