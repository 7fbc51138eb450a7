"""What changed on each robot: its latest period against its reference, from the drift
tests of :func:`ivdyn.fleet.drift` (issue 18, item 3).

A change is an effect (with its joint) flagged on the robot's latest period. Its onset is
the first period of the run of consecutive flagged periods that reaches the latest one
(a change that comes and goes is dated by its last coming); the words are the latest
test's, dated by the onset: "arm-03, elbow_joint: coulomb friction +30 % ± 1 % since
2026-11-05" (the change of the latest period against the reference period, with its 95 %
confidence interval; :func:`ivdyn.fleet.drift` explains the test).
"""
from __future__ import annotations

import json
from typing import Any, Dict, List, Sequence, Tuple

from .. import _ivdyn

__all__ = ["changes", "effect_key"]


def effect_key(t: Dict[str, Any]) -> Tuple[str, str]:
    """An effect of a robot: ``(effect, joint or "")``."""
    return t["effect"], t.get("joint") or ""


def changes(tests: Sequence[Dict[str, Any]]) -> List[Dict[str, Any]]:
    """Per robot, the effects flagged on its latest period: dicts with ``robot``,
    ``effect``, ``joint``, ``period`` (the latest), ``reference_period``, ``since`` (the
    onset), ``flagged_periods``, ``test`` (the latest period's test) and ``words``; by
    robot, then by p-value."""
    by_robot: Dict[str, List[Dict[str, Any]]] = {}
    for t in tests:
        by_robot.setdefault(t["robot"], []).append(t)
    out = []
    for robot in sorted(by_robot):
        rows = by_robot[robot]
        periods = sorted({t["period"] for t in rows})
        latest = periods[-1]
        flagged = {(t["period"],) + effect_key(t) for t in rows if t["flagged"]}
        for t in sorted((t for t in rows if t["period"] == latest and t["flagged"]), key=lambda t: t["p_value"]):
            key = effect_key(t)
            run = [p for p in periods if (p,) + key in flagged]
            since = latest
            for p in reversed(periods):  # back from the latest while flagged
                if (p,) + key not in flagged:
                    break
                since = p
            words = _ivdyn.fleet_describe(robot, json.dumps(_plain(t)), since)
            out.append(dict(robot=robot, effect=t["effect"], joint=t.get("joint"), period=latest,
                            reference_period=t["reference_period"], since=since, flagged_periods=run,
                            test=t, words=words))
    return out


def _plain(t: Dict[str, Any]) -> Dict[str, Any]:
    """The fields of a Rust drift test (the rest are the driver's)."""
    keys = ("effect", "joint", "parameters", "reference", "change", "std", "statistic", "dof", "p_value")
    return {k: t[k] for k in keys}
