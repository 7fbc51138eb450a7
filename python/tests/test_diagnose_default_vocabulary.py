"""The effect vocabulary `diagnose` searches by default (docs/diagnose.md, "Effects of real
drives from 4 s"): the effects of real drives on logs of at least 4 s whose
torque noise is white at the sample rate, the basic vocabulary otherwise.

The log is one case of the CAD set at 20-60 s (`make_cad_cases.py --duration 20:60`, its
tuning part), written by MuJoCo here: the UR3 with CAD inertials 15 % off and smooth (tanh)
friction on `wrist_2_joint`, which the drive vocabulary names as such and the basic one as
Coulomb + viscous friction. The same log with its torque low-passed before the diagnosis
(as the LWR4+ logs of ../shared/data/real were by their authors) has no white noise left:
the drive effects are then left out, and the details say why.
"""
import json
import os
import sys

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "python", "tools"))
import make_cad_cases as mcc  # noqa: E402
from sindy_baseline import lowpass, read_log  # noqa: E402
import ivdyn  # noqa: E402

CASE = "ur3/e15_1fx"


@pytest.fixture(scope="module")
def long_case(tmp_path_factory):
    out = tmp_path_factory.mktemp("cad_long")
    assert mcc.main(["--duration", "20:60", "--only", CASE, "--out", str(out)]) == 0
    with open(out / "ur3" / "cases.json") as f:
        m = json.load(f)
    case = next(c for c in m["cases"] if c["name"] == CASE.split("/")[1])
    assert case["samples"] * mcc.mdc.DT >= 20.0
    return m, case, str(out / "ur3" / case["log"])


def pairs(effects):
    return {(e["name"], tuple(e["joints"])) for e in effects}


def run(m, case, log, **kw):
    return ivdyn.diagnose(case["urdf"], log, base=m["base"], tip=m["tip"], report=False, verdict=True, **kw)


def test_a_long_log_with_white_noise_is_searched_for_drive_effects(long_case):
    m, case, log = long_case
    assert pairs(case["effects"]) == {("smooth_coulomb_friction", ("wrist_2_joint",))}
    d = run(m, case, log)
    assert pairs(d["effects"]) == pairs(case["effects"]), d["effects"]
    assert d["details"][-1].startswith("effects of real drives searched: the log spans"), d["details"]
    basic = run(m, case, log, drives=False)
    assert ("smooth_coulomb_friction", ("wrist_2_joint",)) not in pairs(basic["effects"])
    assert any(j == ("wrist_2_joint",) for _, j in pairs(basic["effects"])), basic["effects"]
    assert basic["details"][-1] == "effects of real drives not searched, as asked"


def test_a_low_passed_torque_is_not_searched_for_drive_effects(long_case):
    m, case, log = long_case
    t, q, qd, tau = read_log(log, m["joints"])
    fs = 1.0 / float(np.median(np.diff(t)))
    smooth = {"t": t, "q": q, "qd": qd, "tau": lowpass(tau, fs, 20.0)}
    d = run(m, case, smooth)
    why = d["details"][-1]
    assert why.startswith("effects of real drives not searched: the torque noise is not white"), why
    assert run(m, case, smooth, drives=True)["details"][-1] == "effects of real drives searched, as asked"
