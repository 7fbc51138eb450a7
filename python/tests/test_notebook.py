"""Notebook use (issue 17, item 4): pandas DataFrames as logs, readable results
(IdentifyResult / PayloadResult / FitReport / BaseParams), ivdyn.plot on an identification,
and one inertia order in the API (URDF's in files), checked against the NumPy reference."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")
sys.path.insert(0, os.path.join(ROOT, "python", "reference"))
from ivdyn_ref import model as rm  # noqa: E402

import pandas as pd
FC = [2, 2, 1.5, 0.6, 0.6, 0.4]
FV = [0.8, 0.8, 0.5, 0.2, 0.2, 0.1]
NOISE = 0.05
WIDTH = 100


@pytest.fixture(scope="module")
def ur5():
    return ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")


@pytest.fixture(scope="module")
def sim(ur5):
    return ivdyn.simulate(ur5, duration=8, seed=11, noise=NOISE, fc=FC, fv=FV)["log"]


def frame(robot, log, fields=("q", "tau"), extra=True):
    """The log as a DataFrame in the CSV layout (plus an unrelated column)."""
    cols = {"t": log["t"]}
    for key in fields:
        suffix = "i" if key == "current" else key
        cols.update({f"{j}.{suffix}": log[key][:, k] for k, j in enumerate(robot.joint_names)})
    if extra:
        cols["gripper_joint.q"] = np.zeros_like(log["t"])
    return pd.DataFrame(cols)


def plain(log):
    """The dict of the same columns as ``frame``'s default."""
    return {"t": log["t"], "q": log["q"], "tau": log["tau"]}


@pytest.fixture(scope="module")
def identified(ur5, sim):
    return ivdyn.identify(ur5, frame(ur5, sim), prediction=True)


# ------------------------------------------------------------------ DataFrames


def test_a_dataframe_is_the_same_log_as_its_dict(ur5, sim, identified):
    by_dict = ivdyn.identify(ur5, plain(sim))
    assert json.dumps(identified, sort_keys=True) == json.dumps(by_dict, sort_keys=True)
    # the time as the index, a list of logs, a validation log
    df = frame(ur5, sim).set_index("t")
    assert ivdyn.identify(ur5, df)["base"] == by_dict["base"]
    two = ivdyn.identify(ur5, [frame(ur5, sim), frame(ur5, sim)], validate=frame(ur5, sim))
    two_d = ivdyn.identify(ur5, [plain(sim), plain(sim)], validate=plain(sim))
    assert two["base"] == two_d["base"] and two["validation"] == two_d["validation"]


def test_payload_takes_dataframes_for_log_and_before(ur5, sim):
    after = ivdyn.simulate(ur5, duration=8, seed=12, noise=NOISE, fc=FC, fv=FV, payload_mass=2.0,
                           payload_com=[0.01, -0.02, 0.05])["log"]
    a = ivdyn.payload(ur5, frame(ur5, after), before=frame(ur5, sim))
    b = ivdyn.payload(ur5, plain(after), before=plain(sim))
    assert a == b and a["identifiable"]


def test_drive_gains_reads_the_current_columns(ur5, sim):
    kt = np.array([13.5, 13.5, 9.3, 4.8, 4.8, 4.8])
    loaded = ivdyn.simulate(ur5, duration=8, seed=13, noise=NOISE, fc=FC, fv=FV, payload_mass=2.0,
                            payload_com=[0.01, -0.02, 0.05])["log"]
    cur = [{"t": x["t"], "q": x["q"], "current": x["tau"] / kt} for x in (sim, loaded)]
    by_frame = ivdyn.drive_gains(ur5, frame(ur5, cur[0], ("q", "current")), frame(ur5, cur[1], ("q", "current")),
                                 payload_mass=2.0)
    assert by_frame == ivdyn.drive_gains(ur5, cur[0], cur[1], payload_mass=2.0)


def test_dataframe_errors_name_the_columns_and_joints(ur5, sim):
    df = frame(ur5, sim).drop(columns=["wrist_3_joint.q"])
    with pytest.raises(ValueError, match=r"log: columns \[wrist_3_joint.q\] are missing \(joints \[wrist_3_joint\]\)"):
        ivdyn.identify(ur5, df)
    df = frame(ur5, sim).drop(columns=["elbow_joint.tau"])
    with pytest.raises(ValueError, match=r"before: columns \[elbow_joint.tau\] are missing .*every joint has it"):
        ivdyn.payload(ur5, frame(ur5, sim), before=df)
    with pytest.raises(ValueError, match=r"validate: the DataFrame has no column 't'"):
        ivdyn.identify(ur5, frame(ur5, sim), validate=frame(ur5, sim).drop(columns=["t"]))
    bad = frame(ur5, sim)
    bad["shoulder_pan_joint.q"] = "x"
    with pytest.raises(ValueError, match=r"log\['q'\] must be an array of real numbers"):
        ivdyn.identify(ur5, bad)


def test_pandas_is_not_imported_for_other_logs():
    code = ("import sys, numpy as np, ivdyn\n"
            f"r = ivdyn.Robot.from_urdf({UR5!r}, base='base_link', tip='tool0')\n"
            "s = ivdyn.simulate(r, duration=2, seed=1, noise=0.05)\n"
            "ivdyn.identify(r, s['log'])\n"
            "print('pandas' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# ------------------------------------------------------------------ readable results


def lines_fit(text: str) -> None:
    long = [ln for ln in text.splitlines() if len(ln) > WIDTH]
    assert not long, f"{len(long)} lines over {WIDTH} characters, e.g. {long[0]!r}"


def test_identify_result_is_its_json_with_a_short_repr(identified):
    rep = identified
    assert isinstance(rep, dict) and isinstance(rep, ivdyn.IdentifyResult)
    assert json.loads(json.dumps(rep)) == dict(rep)
    text = repr(rep)
    lines_fit(text)
    assert text.startswith(f"ivdyn.identify: {rep['method']},") and str(rep) == text
    for k, j in enumerate(rep["joints"]):   # every joint with its fit and validation RMS
        row = next(ln for ln in text.splitlines() if ln.startswith(j))
        assert format(rep["fit"]["rms"][k], ".4g") in row and format(rep["validation"]["rms"][k], ".4g") in row
    top = max(rep["base"], key=lambda b: abs(b["value"]))
    assert format(top["value"], ".4g") in text
    html = rep._repr_html_()
    for b in rep["base"]:
        assert format(b["value"], ".6g") in html and format(b["std"], ".3g") in html
    assert all(j in html for j in rep["joints"])


def test_payload_result_repr_and_html(ur5):
    after = ivdyn.simulate(ur5, duration=8, seed=14, noise=0.01, payload_mass=1.5,
                           payload_com=[0.0, 0.02, 0.04])["log"]
    pl = ivdyn.payload(ur5, after)
    assert isinstance(pl, ivdyn.PayloadResult) and json.loads(json.dumps(pl)) == dict(pl)
    text = repr(pl)
    lines_fit(text)
    assert format(pl["mass"], ".5g") in text and format(pl["rms_after"][0], ".4g") in text
    html = pl._repr_html_()
    assert format(pl["mass"], ".5g") in html and all(format(c, ".4g") in html for c in pl["com"])


def test_fit_report_lines_stay_short_with_long_names():
    rng = np.random.default_rng(3)
    phi = rng.normal(size=(400, 4))
    y = phi @ np.array([1.0, -2.0, 0.5, 3.0]) + 0.01 * rng.normal(size=400)
    names = ["a", " + ".join(f"{0.1 * k:.6f}*link{k}.Ixx" for k in range(20)), "c" * 150, "d"]
    for fit in (ivdyn.fit_ls(phi, y, names=names), ivdyn.fit_iv(phi, phi, y, names=names)):
        text = repr(fit)
        lines_fit(text)
        assert len(names[1]) > 300 and all(t in text for t in ("link0.Ixx", "link19.Ixx"))
        html = fit._repr_html_()
        assert names[1] in html and all(format(v, ".6g") in html for v in fit.theta)


def test_base_params_repr_and_html(ur5):
    bp = ivdyn.base_params(ur5)
    lines_fit(repr(bp))
    html = bp._repr_html_()
    assert all(n in html for n in bp.names[:5]) and f"{bp.base_count} of {bp.full_cols}" in html


# ------------------------------------------------------------------ plots


@pytest.fixture(scope="module")
def plt():
    import matplotlib as mpl
    mpl.use("Agg")
    import matplotlib.pyplot as plt
    yield plt
    plt.close("all")


def test_prediction_is_the_identified_model_on_the_log(ur5, sim, identified):
    p = identified.prediction
    t, n = len(p["t"]), ur5.dof
    assert p["joint_names"] == ur5.joint_names and p["measured"].shape == (t, n) and t > 0.9 * len(sim["t"])
    # the file's residual is measured - predicted, exactly (docs/cli.md)
    assert np.array_equal(p["residual"], p["measured"] - p["predicted"])
    # the predicted torque is the identified parameters' inverse dynamics at the model's state;
    # the identified robot comes from the report's parameter file
    fitted = ur5.copy()
    fitted.params = np.asarray(identified["params"]["theta"])
    dt = np.diff(p["t"]).mean()
    qdd = np.gradient(p["qd"], dt, axis=0)
    inner = slice(50, -50)   # away from the ends, where the differentiated qd is one-sided
    tau = fitted.rnea(p["q"][inner], p["qd"][inner], qdd[inner])
    # central differences of the (smooth) model velocity stand in for the pipeline's own qdd:
    # agreement to ~3e-5 N m here; the nominal model, which lacks the friction, is off by
    # 0.4-2.3 N m, so 1e-3 separates the two by far
    assert np.sqrt(np.mean((tau - p["predicted"][inner]) ** 2)) < 1e-3


def test_torques_and_residuals_plot_the_result_arrays(identified, plt):
    p = identified.prediction
    fig = ivdyn.plot.torques(identified)
    assert len(fig.axes) == 6
    for j, ax in enumerate(fig.axes):
        meas, pred = ax.get_lines()[:2]
        assert np.array_equal(meas.get_xdata(), p["t"]) and np.array_equal(meas.get_ydata(), p["measured"][:, j])
        assert np.array_equal(pred.get_ydata(), p["predicted"][:, j])
    fig = ivdyn.plot.residuals(identified, joints=["elbow_joint", 0])
    (ax_e, ax_0) = fig.axes
    assert np.array_equal(ax_e.get_lines()[0].get_ydata(), p["residual"][:, 2])
    assert np.array_equal(ax_0.get_lines()[0].get_xdata(), p["t"])
    fig = ivdyn.plot.residuals(identified, against="velocity")
    for j, ax in enumerate(fig.axes):
        line = ax.get_lines()[0]
        assert np.array_equal(line.get_xdata(), p["qd"][:, j]) and np.array_equal(line.get_ydata(), p["residual"][:, j])
    with pytest.raises(ValueError, match="against must be"):
        ivdyn.plot.residuals(identified, against="q")
    with pytest.raises(ValueError, match="no joint 'nope'"):
        ivdyn.plot.torques(identified, joints=["nope"])


def test_plots_need_a_prediction(ur5, sim, plt):
    rep = ivdyn.identify(ur5, dict(sim))
    assert rep.prediction is None
    with pytest.raises(ValueError, match="prediction=True"):
        ivdyn.plot.torques(rep)


def test_read_prediction_of_an_out_mcap_file(ur5, sim, tmp_path, identified, plt):
    path = tmp_path / "pred.mcap"
    ivdyn.identify(ur5, frame(ur5, sim), out_mcap=path)
    p = ivdyn.read_prediction(path, ur5)
    for k in ("t", "q", "qd", "measured", "predicted", "residual"):
        assert np.array_equal(p[k], identified.prediction[k]), k
    fig = ivdyn.plot.torques(p, joints=[5])
    assert np.array_equal(fig.axes[0].get_lines()[1].get_ydata(), p["predicted"][:, 5])


def test_parameter_table_holds_every_base_parameter(identified, plt):
    fig = ivdyn.plot.parameters(identified, max_name=1000)
    (table,) = fig.axes[0].tables
    cells = table.get_celld()
    rows = ivdyn.plot.parameter_rows(identified)
    assert len(rows) == len(identified["base"])
    for r, (b, row) in enumerate(zip(identified["base"], rows), start=1):
        assert row[1] == format(b["value"], ".4g") and row[2] == format(b["std"], ".2g")
        assert [cells[(r, c)].get_text().get_text() for c in range(4)] == row


# ------------------------------------------------------------------ one inertia order


I_C = np.array([0.004, 0.0002, 0.005, -0.0001, 0.0003, 0.003])   # Ixx, Ixy, Iyy, Ixz, Iyz, Izz
MASS, COM = 2.0, [0.01, -0.02, 0.05]


def test_the_order_names_match_the_parameter_layout(ur5):
    assert ivdyn.INERTIA_ORDER == ["Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz"]
    assert [n.split(".")[-1] for n in ur5.param_names[4:10]] == ivdyn.INERTIA_ORDER
    assert ivdyn.INERTIA_URDF_ORDER == ["Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"]
    x = np.arange(12.0).reshape(2, 6)
    u = ivdyn.inertia_to_urdf(x)
    # each named entry lands where the other order names it
    for k, name in enumerate(ivdyn.INERTIA_ORDER):
        assert np.array_equal(u[:, ivdyn.INERTIA_URDF_ORDER.index(name)], x[:, k])
    assert np.array_equal(ivdyn.inertia_from_urdf(u), x)
    with pytest.raises(ValueError, match=r"inertia must have shape \(6,\)"):
        ivdyn.inertia_to_urdf([1.0, 2.0])


def test_simulate_payload_inertia_is_in_ivdyn_order(ur5):
    """The true model of a simulation with an asymmetric payload inertia (Iyy != Ixz) against
    the NumPy reference's URDF <inertial> conversion, given the URDF-order values."""
    res = ivdyn.simulate(ur5, duration=1, payload_mass=MASS, payload_com=COM, payload_inertia=I_C)
    theta = np.asarray(res["true_params"]["theta"])
    added = theta[50:60] - ur5.params[50:60]
    ixx, ixy, ixz, iyy, iyz, izz = ivdyn.inertia_to_urdf(I_C)
    want = rm.inertial_from_urdf(MASS, COM, (0, 0, 0), ixx, ixy, ixz, iyy, iyz, izz)
    np.testing.assert_allclose(added, want, rtol=1e-12, atol=1e-15)
    swapped = rm.inertial_from_urdf(MASS, COM, (0, 0, 0), *I_C)   # the order mistaken for URDF's
    assert np.abs(added - swapped).max() > 1e-3


def test_payload_json_keeps_urdf_order_and_payload_from_fit_ivdyn_order(ur5):
    log = ivdyn.simulate(ur5, duration=10, seed=8, noise=0.01, payload_mass=MASS, payload_com=COM,
                         payload_inertia=I_C)["log"]
    pl = ivdyn.payload(ur5, log)
    # the report's inertia in URDF order is the reference's reading of its own 10 parameters
    ref = rm.inertial_to_urdf(np.asarray(pl["params"]))
    np.testing.assert_allclose(pl["inertia"], [ref[k] for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")],
                               rtol=1e-9, atol=1e-12)
    got, std = ivdyn.inertia_from_urdf(pl["inertia"]), ivdyn.inertia_from_urdf(pl["inertia_std"])
    assert np.all(np.abs(got - I_C) < 4 * std), (got, I_C, std)


def test_payload_from_fit_inertia_is_in_ivdyn_order(ur5):
    """Noise-free torques of the arm with the payload added (its 10 parameters from the NumPy
    reference): payload_from_fit gives back I_C in ivdyn's order."""
    ixx, ixy, ixz, iyy, iyz, izz = ivdyn.inertia_to_urdf(I_C)
    truth = ur5.copy()
    theta = truth.params
    theta[50:60] += rm.inertial_from_urdf(MASS, COM, (0, 0, 0), ixx, ixy, ixz, iyy, iyz, izz)
    truth.params = theta
    rng = np.random.default_rng(5)
    Q, QD, QDD = rng.uniform(-np.pi, np.pi, (300, 6)), rng.uniform(-1, 1, (300, 6)), rng.uniform(-2, 2, (300, 6))
    tb = ivdyn.terminal_base(ur5, first_row=0)          # over the last link's 10 columns
    Phi = tb.select(ur5.regressor(Q, QD, QDD)[:, :, 50:60]).reshape(-1, tb.base_count)
    fit = ivdyn.fit_ls(Phi, (truth.rnea(Q, QD, QDD) - ur5.rnea(Q, QD, QDD)).ravel(), names=tb.names)
    est = ivdyn.payload_from_fit(tb, fit, list(range(10)), ur5.param_names[50:60])
    np.testing.assert_allclose(est["inertia"], I_C, atol=1e-9)
    np.testing.assert_allclose(est["com"], COM, atol=1e-9)


def test_cli_payload_inertia_is_in_urdf_order(ur5, ivdyn_bin, tmp_path):
    out = tmp_path / "s.json"
    u = ivdyn.inertia_to_urdf(I_C)
    subprocess.run([ivdyn_bin, "simulate", "--urdf", UR5, "--base", "base_link", "--tip", "tool0", "--duration", "1",
                    "--payload-mass", str(MASS), "--payload-com", ",".join(map(str, COM)),
                    "--payload-inertia", ",".join(repr(float(v)) for v in u), "--out", str(tmp_path / "s.csv"),
                    "--json", str(out), "--quiet"], check=True)
    cli = json.loads(out.read_text())["true_params"]["theta"]
    py = ivdyn.simulate(ur5, duration=1, payload_mass=MASS, payload_com=COM, payload_inertia=I_C)["true_params"]["theta"]
    np.testing.assert_allclose(cli, py, rtol=0, atol=0)
