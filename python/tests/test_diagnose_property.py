"""Property (issue 15, item 5): any combination of up to three effects, on random joints of a
randomly generated arm, with inertial errors of 5-30 % in the nominal URDF and any sensor
variant (jittered stamps with re-published samples, float32, no velocity, motor current),
runs `ivdyn diagnose` to a valid diagnosis.json (the shape of ../shared/DESIGN.md and
docs/diagnose.md, "diagnosis.json") and a complete report.html: never an internal error.

The logs come from MuJoCo through make_cad_cases.py (random_arm.py writes the arm as URDF
for ivdyn and as MJCF for MuJoCo; the same effect and sensor code as the scored sets).
Whether the diagnosis names the right effects is not asserted here: that is a score
(python/tools/score_diagnose_cases.py), not a property.

Seeded. The regular suite runs PROPERTY_CASES cases of 2 s (dev build: 8 CPU s for the three,
imports included); `IVDYN_PROPERTY_CASES=200` runs more locally, `IVDYN_PROPERTY_SEED` shifts
the seeds.
"""
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
sys.path.insert(0, os.path.join(ROOT, "python", "tools"))
import make_cad_cases as mcc  # noqa: E402
import ivdyn  # noqa: E402

PROPERTY_CASES = int(os.environ.get("IVDYN_PROPERTY_CASES", "3"))
SEED0 = int(os.environ.get("IVDYN_PROPERTY_SEED", "0"))
DURATION_S = 2.0

# docs/diagnose.md, "diagnosis.json": the parameters of each effect; per-joint lists unless
# the effect is the payload
PARAMETERS = {
    "coulomb_friction": {"fc"}, "viscous_friction": {"fv"}, "stribeck_friction": {"fc", "fs", "vs"},
    "armature": {"ia"}, "torque_offset": {"tau0"}, "joint_spring": {"k", "q0"},
    "asymmetric_coulomb_friction": {"fc_pos", "fc_neg"}, "smooth_coulomb_friction": {"fc", "vs"},
    "load_dependent_friction": {"mu"}, "torque_gain": {"k"}, "torque_ripple": {"period", "a", "b"},
    "time_delay": {"delay_s"}, "payload": {"mass", "com", "inertia"},
}
TOP = {"effects", "baseline_rms", "final_rms", "joints", "detectable"}
OPTIONAL_TOP = {"nominal_refit", "next_command"}
DETECTABLE = ("torque_offset", "asymmetric_coulomb_friction", "joint_spring", "torque_gain", "armature")


def make_case(index, out):
    """Case `index`: a random arm (6 or 7 joints), 0-3 effects of distinct kinds (the basic
    and the drive vocabulary) on random joints, a nominal error level, a sensor variant, and
    whether the drive vocabulary is searched. Returns (cfg, entry, nominal, drives)."""
    seed = 70_000 + 10 * (SEED0 + index)
    rng = np.random.default_rng(seed)
    n = int(rng.choice([6, 7]))
    cfg = mcc.random_config(f"prop{index}", out, joints_seed=(n, 20_000 + SEED0 + index))
    robot = ivdyn.Robot.from_urdf(cfg["urdf_path"], base=cfg["base"], tip=cfg["tip"])
    names = list(robot.joint_names)
    count = int(rng.integers(0, 4))
    case = {"name": f"case{index}", "seed": seed}
    case["effects"] = mcc.draw_effects(cfg, robot, names, seed, count, rng, mcc.KINDS + mcc.DRIVE_KINDS)
    nominal = os.path.join(out, f"case{index}_nominal.urdf")
    mcc.nominal_urdf(cfg, nominal, float(rng.choice(mcc.LEVELS)), rng)
    entry = mcc.write_case(cfg, robot, case, nominal, DURATION_S)
    return cfg, entry, nominal, bool(rng.random() < 0.5)


def finite_list(x, n, what):
    assert isinstance(x, list) and len(x) == n, f"{what}: {x!r} is not a list of {n}"
    assert all(isinstance(v, (int, float)) and math.isfinite(v) for v in x), f"{what}: {x!r}"


def check_effect(e, joints, refit=False):
    n = len(joints)
    assert set(e) == {"name", "joints", "parameters", "parameters_std", "rms_before", "rms_after"}, e.keys()
    name = e["name"]
    assert name in PARAMETERS, name
    assert isinstance(e["joints"], list) and len(set(e["joints"])) == len(e["joints"]), e["joints"]
    assert set(e["joints"]) <= set(joints), e["joints"]
    assert set(e["parameters"]) == PARAMETERS[name], (name, e["parameters"].keys())
    assert set(e["parameters_std"]) == PARAMETERS[name], (name, e["parameters_std"].keys())
    if name == "payload":
        assert e["joints"] == []
        p = e["parameters"]
        if p["mass"] is None:
            # on top of the nominal re-fit a mass not separable from the previous link's CAD
            # mass: no mass, no centre of mass, no inertia about it (docs/diagnose.md)
            assert refit and p["com"] is None and p["inertia"] is None, p
        else:
            assert isinstance(p["mass"], float) and math.isfinite(p["mass"]) and p["mass"] > 0, p
            finite_list(p["com"], 3, "payload com")
            finite_list(p["inertia"], 6, "payload inertia")
    else:
        assert e["joints"], f"{name} on no joint"
        for k, v in e["parameters"].items():
            finite_list(v, len(e["joints"]), f"{name}.{k}")
    for k, v in e["parameters_std"].items():   # null where there is none, else the parameter's shape
        ref = e["parameters"][k]
        if v is None:
            continue
        if isinstance(ref, list):
            assert isinstance(v, list) and len(v) == len(ref), (name, k, v)
            assert all(s is None or (math.isfinite(s) and s >= 0) for s in v), (name, k, v)
        else:
            assert math.isfinite(v) and v >= 0, (name, k, v)
    finite_list(e["rms_before"], n, f"{name} rms_before")
    finite_list(e["rms_after"], n, f"{name} rms_after")


def check_diagnosis(d, joints):
    """diagnosis.json has DESIGN.md's shape with the documented added keys, finite numbers."""
    assert TOP <= set(d) <= TOP | OPTIONAL_TOP, sorted(d)
    assert d["joints"] == joints
    n = len(joints)
    for key in ("baseline_rms", "final_rms"):
        finite_list(d[key], n, key)
        assert min(d[key]) >= 0, (key, d[key])
    for e in d["effects"]:
        check_effect(e, joints, refit=d.get("nominal_refit") is not None)
    if "nominal_refit" in d:
        r = d["nominal_refit"]
        assert set(r) == {"base_params", "rms_before", "rms_after", "why"}, r.keys()
        bp = r["base_params"]
        assert set(bp) == {"names", "nominal", "values"}
        assert len(bp["names"]) == len(bp["nominal"]) == len(bp["values"]) > 0
        finite_list(bp["nominal"], len(bp["names"]), "base_params.nominal")
        finite_list(bp["values"], len(bp["names"]), "base_params.values")
        finite_list(r["rms_before"], n, "nominal_refit.rms_before")
        finite_list(r["rms_after"], n, "nominal_refit.rms_after")
        assert isinstance(r["why"], str) and r["why"]
    if "next_command" in d:
        assert d["next_command"].startswith("ivdyn identify "), d["next_command"]
    det = d["detectable"]
    assert det["noise_std"] == 2.0 and set(det) == {"noise_std", "sigma", *DETECTABLE}, sorted(det)
    finite_list(det["sigma"], n, "detectable.sigma")
    for kind in DETECTABLE:
        assert len(det[kind]) == n and all(v is None or (math.isfinite(v) and v > 0) for v in det[kind]), (kind, det[kind])


def check_report(path, d):
    with open(path, encoding="utf-8") as f:
        html = f.read()
    assert html.lstrip().lower().startswith("<!doctype html") and html.rstrip().endswith("</html>")
    assert "data:image/png;base64," in html
    for e in d["effects"]:
        assert e["name"] in html, e["name"]


def run_diagnose(ivdyn_bin, cfg, entry, nominal, drives, out):
    log = os.path.join(os.path.dirname(nominal), entry["log"])
    cmd = [ivdyn_bin, "--quiet", "diagnose", "--urdf", nominal, "--base", cfg["base"], "--tip", cfg["tip"],
           "--log", log, "--out", out] + entry["diagnose_args"] + (["--drives"] if drives else ["--no-drives"])
    return cmd, subprocess.run(cmd, capture_output=True, text=True)


@pytest.mark.parametrize("index", range(PROPERTY_CASES))
def test_any_effects_on_a_random_arm_give_a_valid_diagnosis(index, tmp_path, ivdyn_bin):
    cfg, entry, nominal, drives = make_case(index, str(tmp_path))
    out = str(tmp_path / "out")
    cmd, res = run_diagnose(ivdyn_bin, cfg, entry, nominal, drives, out)
    what = f"case {index}: effects {[(e['name'], e['joints']) for e in entry['effects']]}, sensor {entry['sensor']}"
    assert res.returncode == 0, f"{what}\n{' '.join(cmd)}\n{res.stderr}"
    assert "panicked" not in res.stderr and "internal error" not in res.stderr.lower(), res.stderr
    with open(os.path.join(out, "diagnosis.json")) as f:
        d = json.load(f)
    check_diagnosis(d, [f"joint_{i}" for i in range(1, len(cfg["centres"]) + 1)])
    check_report(os.path.join(out, "report.html"), d)
    assert os.path.getsize(os.path.join(out, "residuals.mcap")) > 0
