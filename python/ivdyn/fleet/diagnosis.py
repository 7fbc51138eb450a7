"""What changed, named by the diagnosis (issue 18, item 3): for each robot with a change
on its latest period, ``ivdyn``'s model-gap diagnosis (:func:`ivdyn.diagnose`, the app
layer's one orchestration) of the latest period's logs, with the model identified on the
robot's reference period as the nominal model (its parameter file, ``params=``): what
the reference model now misses, from the diagnosis's vocabulary (``coulomb_friction``,
``viscous_friction``, ``armature``, ``torque_offset``, ``payload``, ...), on which
joints and how much, in words::

    arm-03, elbow_joint: coulomb friction +0.44 N m ± 0.02 N m (+29 % of 1.52 N m) since 2026-11-05

And when the drift flags the payload, its mass (:func:`ivdyn.payload`, the app layer's
payload estimate, on the latest log with the reference period's log as the before-log:
the unloaded arm identified on it, its uncertainty carried into the mass's)::

    arm-07: payload +1.49 kg ± 0.04 kg since 2026-11-07

or why the data do not determine it. A payload is never physically impossible: the mass
is the physically possible payload's (:func:`ivdyn.payload`); a payload taken off (a
least-squares mass below zero) is estimated the other way round (the reference log after
the latest one) and stated as a negative change.

The values are the diagnosis's, with 95 % intervals (1.96 of its standard errors). A
change is dated by the onset of the drift test of the same effect and joint
(:func:`ivdyn.fleet.changes`) when there is one, else by the latest period ("on ...").
"""
from __future__ import annotations

import dataclasses
import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Dict, List, Optional, Sequence, Tuple

from .._pipeline import diagnose as _diagnose
from .._pipeline import payload as _payload
from .changes import changes as latest_changes

__all__ = ["diagnose", "Diagnosis", "effect_words", "payload_words"]

#: Half-width of the two-sided 95 % normal interval, in standard deviations (as the drift
#: words' ``CI95``).
CI95 = 1.959963984540054

#: The diagnosis's effects and the drift test that dates them (same effect, same joint).
DRIFT_EFFECT = {
    "coulomb_friction": "coulomb_friction", "stribeck_friction": "coulomb_friction",
    "asymmetric_coulomb_friction": "coulomb_friction", "smooth_coulomb_friction": "coulomb_friction",
    "viscous_friction": "viscous_friction", "armature": "armature", "torque_offset": "torque_offset",
    "payload": "payload",
}
#: Units of the diagnosis's parameters (``docs/diagnose.md``), and the reference model's
#: parameter a change is a percentage of (``<joint>.<suffix>``).
UNITS = {"fc": "N m", "fv": "N m s/rad", "ia": "kg m^2", "tau0": "N m", "fs": "N m", "vs": "rad/s",
         "k": "N m/rad", "q0": "rad", "fc_pos": "N m", "fc_neg": "N m", "mu": "", "delay_s": "s",
         "period": "rad", "a": "N m", "b": "N m"}
#: Keys whose unit depends on the effect: a torque gain's ``k`` is a ratio, a spring's N m/rad.
UNITS_OF_EFFECT = {("torque_gain", "k"): ""}
OF_REFERENCE = {"fc": "fc", "fv": "fv", "ia": "ia", "fc_pos": "fc", "fc_neg": "fc"}
#: How the diagnosis's details start a residual it left above the noise (and why it named
#: nothing there).
LEFT = "left above the noise: "


@dataclasses.dataclass(frozen=True)
class Job:
    """One diagnosis: the latest period's log of ``robot`` against the reference period's
    model (``params``: its parameter file) and, for the payload, the reference log."""
    robot: str
    period: str
    reference_period: str
    log: str
    model: str
    base: Optional[str]
    tip: Optional[str]
    params: Dict[str, Any]
    reference_log: Optional[str]
    payload: bool


Diagnosis = Dict[str, Any]


def _latest_log(result, robot: str, period: str) -> Optional[Any]:
    """The last usable log of ``robot`` in ``period`` (by time, then path)."""
    ok = {(r["log"], r["robot"], r["period"]) for r in result.rows if r["status"] == "ok"}
    es = [e for e in result.entries if e.robot == robot and e.period == period and (e.log, robot, period) in ok]
    return max(es, key=lambda e: (e.time or "", e.log), default=None)


def jobs(result, tests: Sequence[Dict[str, Any]], robots: Optional[Sequence[str]] = None) -> List[Job]:
    """The diagnoses to run: each robot with a change on its latest period (or each of
    ``robots``), its latest period's last log against its reference period's fit."""
    ch = latest_changes(tests)
    chosen = sorted({c["robot"] for c in ch}) if robots is None else list(robots)
    out = []
    for robot in chosen:
        rows = [t for t in tests if t["robot"] == robot]
        if not rows:
            raise ValueError(f"{robot}: no drift tests (one period only, or no usable log)")
        period = max(t["period"] for t in rows)
        ref = rows[0]["reference_period"]
        fit = result.fits.get((robot, ref), {})
        latest = _latest_log(result, robot, period)
        if "report" not in fit or latest is None:
            continue  # its fit or logs failed: the rows say why
        ref_log = _latest_log(result, robot, ref)
        pay = any(c["robot"] == robot and c["effect"] == "payload" for c in ch)
        out.append(Job(robot=robot, period=period, reference_period=ref, log=latest.log, model=latest.model,
                       base=latest.base, tip=latest.tip, params=fit["report"]["params"],
                       reference_log=None if ref_log is None else ref_log.log, payload=pay))
    return out


def run_job(job: Job, alpha: float = 1e-3, min_effect: float = 0.5) -> Diagnosis:
    """The diagnosis of one :class:`Job` (and its payload), or ``{"error": ...}``."""
    try:
        d = _diagnose(job.model, job.log, base=job.base, tip=job.tip, params=job.params, report=False,
                      alpha=alpha, min_effect=min_effect, verdict=True)
    except Exception as e:  # noqa: BLE001 -- one robot's failure must not stop the others
        return dict(robot=job.robot, period=job.period, log=job.log, error=f"{job.log}: diagnosis: {e}")
    out = dict(robot=job.robot, period=job.period, reference_period=job.reference_period, log=job.log,
               effects=d["effects"], nominal_refit=d.get("nominal_refit"), baseline_rms=d["baseline_rms"],
               final_rms=d["final_rms"], verdict=d["verdict"],
               left=[x[len(LEFT):] for x in d["details"] if x.startswith(LEFT)], payload=None)
    if job.payload:
        out["payload"] = payload_change(job)
    return out


def payload_change(job: Job) -> Dict[str, Any]:
    """The payload added since the reference period (:func:`ivdyn.payload` of the latest log
    with the reference log as the before-log), or taken off (least-squares mass below zero:
    the other way round, stated negative): ``mass`` (kg, signed), ``mass_std``,
    ``identifiable``, ``why`` (when not determined) and the payload report (``report``)."""
    if job.reference_log is None:
        return dict(identifiable=False, mass=None, mass_std=None, why="the reference period has no usable log")
    try:
        rep = _payload(job.model, job.log, before=job.reference_log, base=job.base, tip=job.tip)
        sign = 1.0
        if rep["identifiable"] and rep["physical"]["ls_params"][0] < 0.0:
            rep, sign = _payload(job.model, job.reference_log, before=job.log, base=job.base, tip=job.tip), -1.0
    except Exception as e:  # noqa: BLE001 -- said in the words
        return dict(identifiable=False, mass=None, mass_std=None, why=f"the payload estimate failed: {e}")
    if not rep["identifiable"]:
        return dict(identifiable=False, mass=None, mass_std=None, report=rep, why=_why_hidden(rep))
    return dict(identifiable=True, mass=sign * rep["mass"], mass_std=rep["mass_std"], report=rep, why=None)


def _why_hidden(rep: Dict[str, Any]) -> str:
    """Why a payload report has no mass: the combination that hides the mass, or the other
    parameters the logs do not separate (``ivdyn payload`` states a mass only when all ten
    of the last link's parameters are determined)."""
    hidden = rep["not_identifiable"]
    mass = next((h for h in hidden if h["parameter"].endswith(".m")), None)
    if mass is not None:
        return (f"the logs' motion determines {mass['parameter']} only in the combination "
                f"{mass['combined_in']}")
    names = ", ".join(h["parameter"] for h in hidden)
    return (f"the logs' motion does not separate {names} from other parameters of {rep['link']}, and "
            "ivdyn payload states a mass only when all ten are determined")


def _fmt(x: float, ci: float) -> Tuple[str, str]:
    """``x`` and ``ci`` to the digits the interval supports (two significant in ``ci``)."""
    import math

    digits = max(0, 1 - int(math.floor(math.log10(ci)))) if ci > 0 and math.isfinite(ci) else 3
    return f"{x:+.{digits}f}", f"{ci:.{digits}f}"


def effect_words(robot: str, e: Dict[str, Any], params: Dict[str, Any], since: Dict[Tuple[str, str], str],
                 period: str) -> List[str]:
    """The words of one effect of a diagnosis: one sentence per joint and parameter (the
    payload's mass, with its centre of mass)."""
    label = e["name"].replace("_", " ")
    std = e.get("parameters_std") or {}
    theta = dict(zip(params.get("names", []), params.get("theta", [])))
    out = []
    if e["name"] == "payload":
        m, s = e["parameters"].get("mass"), (std.get("mass") or None)
        when = _when(since, "payload", "", period)
        if m is None:
            return [f"{robot}: payload {when} (the diagnosis names it; its mass is not determined)"]
        v, ci = _fmt(m, CI95 * s) if s else (f"{m:+.2f}", None)
        return [f"{robot}: payload {v} kg{'' if ci is None else f' ± {ci} kg'} {when} (diagnosis)"]
    lists = {k: v for k, v in e["parameters"].items() if isinstance(v, list)}
    for key, values in lists.items():
        given = std.get(key)
        sds: List[Optional[float]] = list(given) if isinstance(given, list) else [None] * len(values)
        for j, (joint, x) in enumerate(zip(e["joints"], values)):
            if x is None:
                continue
            unit = UNITS_OF_EFFECT.get((e["name"], key), UNITS.get(key, ""))
            s = sds[j] if j < len(sds) else None
            v, ci = _fmt(x, CI95 * s) if s else (f"{x:+.3g}", None)
            named = f"{label} ({key})" if len(lists) > 1 else label
            text = f"{robot}, {joint}: {named} {v}{' ' + unit if unit else ''}"
            if ci is not None:
                text += f" ± {ci}{' ' + unit if unit else ''}"
            ref = theta.get(f"{joint}.{OF_REFERENCE.get(key, '-')}")
            if ref is not None and abs(ref) > 0 and (s is None or abs(ref) > 2 * s):
                text += f" ({100 * x / abs(ref):+.0f} % of {ref:.3g}{' ' + unit if unit else ''})"
            out.append(f"{text} {_when(since, DRIFT_EFFECT.get(e['name'], ''), joint, period)}")
    return out


def payload_words(robot: str, p: Dict[str, Any], since: Dict[Tuple[str, str], str], period: str) -> str:
    """The payload's change in kg, or why the data do not determine it."""
    when = _when(since, "payload", "", period)
    if not p.get("identifiable"):
        return f"{robot}: payload changed {when}; its mass is not determined: {p.get('why')}"
    v, ci = _fmt(p["mass"], CI95 * p["mass_std"])
    return f"{robot}: payload {v} kg ± {ci} kg {when}"


def _when(since: Dict[Tuple[str, str], str], effect: str, joint: str, period: str) -> str:
    s = since.get((effect, joint))
    return f"since {s}" if s else f"on {period}"


def words(d: Diagnosis, tests: Sequence[Dict[str, Any]], params: Dict[str, Any]) -> List[str]:
    """Every sentence of a robot's diagnosis: its named effects, its payload in kg."""
    if "error" in d:
        return [d["error"]]
    since = {(c["effect"], c.get("joint") or ""): c["since"] for c in latest_changes(tests)
             if c["robot"] == d["robot"]}
    out = []
    for e in d["effects"]:
        if e["name"] == "payload" and d.get("payload") is not None:
            continue  # the payload estimate's words below say it with its uncertainty
        out += effect_words(d["robot"], e, params, since, d["period"])
    if d.get("payload") is not None:
        out.append(payload_words(d["robot"], d["payload"], since, d["period"]))
    log = os.path.basename(d["log"])
    if not d["effects"]:
        v = d["verdict"].replace(" (details below)", "")  # the details follow, as sentences of their own
        out.insert(0, f"{d['robot']}: the diagnosis of {log} against the model of {d['reference_period']} names "
                      f"no effect: {v[:1].lower()}{v[1:]}")
    out += [f"{d['robot']}: left above the noise in {log}: {x}" for x in d["left"]]
    return out


def diagnose(result, tests: Sequence[Dict[str, Any]], *, robots: Optional[Sequence[str]] = None,
             engine: str = "local", address: Optional[str] = None, num_cpus: Optional[int] = None,
             alpha: float = 1e-3, min_effect: float = 0.5) -> List[Diagnosis]:
    """Per robot with a change on its latest period (or each of ``robots``): the diagnosis
    of its latest period's last log against its reference period's model (module
    docstring). One dict per robot: ``robot``, ``period``, ``reference_period``, ``log``,
    ``effects`` (``diagnosis.json``'s: ``name``, ``joints``, ``parameters``,
    ``parameters_std``, ...), ``nominal_refit``, ``payload`` (when the payload's drift is
    flagged: :func:`payload_change`) and ``words``; or ``error``. ``engine``: ``"local"``
    (threads) or ``"ray"`` (one task per robot); ``alpha``, ``min_effect``: the
    diagnosis's (:func:`ivdyn.diagnose`)."""
    todo = jobs(result, tests, robots)
    if engine == "ray":
        from ._ray import map_ray
        done = map_ray(run_job, todo, address, num_cpus, alpha, min_effect)
    elif engine == "local":
        with ThreadPoolExecutor(max_workers=num_cpus or os.cpu_count() or 1) as ex:
            done = list(ex.map(lambda j: run_job(j, alpha, min_effect), todo))
    else:
        raise ValueError(f"engine must be 'ray' or 'local', got {engine!r}")
    for j, d in zip(todo, done):
        d["words"] = words(d, tests, j.params)
    return done
