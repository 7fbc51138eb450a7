"""The plain least-squares floor of a data set, and ivdyn's defaults against it.

The floor is what a careful user gets with NumPy alone: the regressor of the NumPy
reference (``python/reference/ivdyn_ref``, rigid body 10 per link + Coulomb, viscous,
armature, offset per joint: the drive terms ivdyn identifies by default), fed with the
log's own velocities (and accelerations when the log has them, else ``np.gradient`` of the
velocity; a log without velocities gets ``np.gradient`` of the positions), ordinary least
squares (``np.linalg.lstsq``) on the first 75 % of the log, R^2 per joint on the last 25 %
against the raw measured torque. Logs faster than 500 Hz are block-averaged down to it
first (the FIGAROH check's low-pass; all signals alike).

ivdyn runs with its defaults (``ivdyn.identify(robot, log)``: WLS, holdout 0.25, no
per-data-set option). Two numbers per joint: ivdyn's own validation R^2 (its parallel-
filtered torque), and ivdyn's identified parameters evaluated on the floor's validation
rows (the same rows, raw torque: the like-for-like comparison).

    python python/tools/ls_floor.py --real ../shared/data/real            # both real arms
    python python/tools/ls_floor.py --urdf arm.urdf --tip flange --log run.mcap
    ... --markdown out.md --json out.json

Prints a table; ``--markdown`` writes it for docs/real-data.md.
"""

import argparse
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "reference"))
from ivdyn_ref import dynamics, model as refmodel  # noqa: E402

MAX_RATE = 500.0
MAX_ROWS = 8000
FIT_SHARE = 0.75


def block_average(x, k):
    """Means of consecutive blocks of k rows (the tail that does not fill a block is dropped)."""
    if k <= 1:
        return x
    m = (len(x) // k) * k
    return x[:m].reshape(m // k, k, *x.shape[1:]).mean(axis=1)


def floor_signals(log):
    """(q, qd, qdd, tau) of the floor from a log dict (t, q, tau, optional qd, qdd)."""
    t = np.asarray(log["t"], float)
    k = max(1, int(np.floor((1.0 / np.median(np.diff(t))) / MAX_RATE)))
    t = block_average(t, k)
    q, tau = block_average(log["q"], k), block_average(log["tau"], k)
    if log.get("qd") is not None:
        qd = block_average(log["qd"], k)
    else:
        qd = np.gradient(q, t, axis=0)
    qdd = block_average(log["qdd"], k) if log.get("qdd") is not None else np.gradient(qd, t, axis=0)
    return q, qd, qdd, tau


def rows(m, q, qd, qdd, idx, coulomb=None):
    return np.vstack([dynamics.regressor(m, q[i], qd[i], qdd[i], coulomb=coulomb) for i in idx])


def r2(y, yhat):
    """1 - SSE / SST per joint (ivdyn's definition, report::quality_of)."""
    sst = ((y - y.mean(axis=0)) ** 2).sum(axis=0)
    return 1.0 - ((y - yhat) ** 2).sum(axis=0) / sst


def floor(m, q, qd, qdd, tau):
    """Floor R^2 per joint, the validation rows used, and a predictor for any theta."""
    t = len(q)
    cut = int(FIT_SHARE * t)
    step = max(1, cut // MAX_ROWS)
    fit_idx = np.arange(0, cut, step)
    val_idx = np.arange(cut, t, max(1, (t - cut) // MAX_ROWS))
    theta, *_ = np.linalg.lstsq(rows(m, q, qd, qdd, fit_idx), tau[fit_idx].ravel(), rcond=None)
    yv = rows(m, q, qd, qdd, val_idx)
    n = q.shape[1]

    def predict(th, coulomb=None):
        y = yv if coulomb is None else rows(m, q, qd, qdd, val_idx, coulomb)
        return (y @ th).reshape(len(val_idx), n)
    return r2(tau[val_idx], predict(theta)), (tau[val_idx], predict)


def compare(name, urdf, log, base=None, tip=None):
    import ivdyn
    m = refmodel.from_urdf(urdf, base, tip)
    q, qd, qdd, tau = floor_signals(log)
    fl, (yval, predict) = floor(m, q, qd, qdd, tau)
    arrays = {k: log[k] for k in ("t", "q", "qd", "tau") if log.get(k) is not None}
    rep = ivdyn.identify(ivdyn.Robot.from_urdf(urdf, base, tip), arrays)
    own = np.array([np.nan if v is None else v for v in rep["validation"]["r2"]])
    shapes = rep["params"].get("coulomb")
    shapes = None if shapes is None else [(c["v_scale"], c["asym"]) for c in shapes]
    same_rows = r2(yval, predict(np.asarray(rep["params"]["theta"], float), shapes))
    vel = [v["source"] for v in rep["conditioning"]["velocity"]]
    return {"data": name, "joints": rep["joints"], "floor": fl.tolist(), "ivdyn": own.tolist(),
            "ivdyn_on_floor_rows": same_rows.tolist(), "velocity": vel, "notes": rep["notes"],
            "coulomb": [c["shape"] for c in rep["coulomb"]] or ["sign"] * len(rep["joints"])}


def kuka(root):
    d = os.path.join(root, "kuka_lwr4p_flobaroid")
    out = []
    for i in (1, 2, 3):
        z = np.load(os.path.join(d, f"measurements_{i}.npz"), allow_pickle=False)
        t = z["times"] - z["times"][0]
        log = {"t": t, "q": z["positions"], "qd": z["velocities"], "qdd": z["accelerations"], "tau": z["torques"]}
        out.append(compare(f"KUKA LWR4+ measurements_{i}", os.path.join(d, "kuka_lwr4.urdf"), log))
    return out


def tx40(root):
    """The TX40 on the joint side (README: q = R^-1 theta_m + offsets, tau = R^T tau_m)."""
    d = os.path.join(root, "staubli_tx40_figaroh")
    qm = np.loadtxt(os.path.join(d, "pos_read_data.csv"), delimiter=",", skiprows=1)
    tm = np.loadtxt(os.path.join(d, "curr_data.csv"), delimiter=",", skiprows=1)
    ratio = np.array([32.0, 32.0, 45.0, -48.0, 45.0, 32.0])
    R = np.diag(ratio)
    R[5, 4] = ratio[5]
    q = np.linalg.solve(R, qm.T).T + np.array([0.0, -np.pi / 2, np.pi / 2, 0.0, 0.0, 0.0])
    tau = tm @ R
    t = np.arange(len(q)) * 2e-4
    return [compare("Staubli TX40 (joint side)", os.path.join(d, "tx40_mdh_modified.urdf"), {"t": t, "q": q, "tau": tau})]


def generic(urdf, path, base, tip):
    import ivdyn
    robot = ivdyn.Robot.from_urdf(urdf, base, tip)
    log = ivdyn.read_joint_states(path, robot) if str(path).endswith(".mcap") else ivdyn.read_csv(path, robot)
    return [compare(os.path.basename(path), urdf, dict(log), base, tip)]


def table(results):
    lines = []
    for r in results:
        n = len(r["joints"])
        lines.append(f"\n**{r['data']}** (velocity: {', '.join(sorted(set(r['velocity'])))})\n")
        lines.append("| validation R² | " + " | ".join(f"j{j + 1}" for j in range(n)) + " |")
        lines.append("|---|" + "---|" * n)
        for key, label in (("floor", "plain LS floor (NumPy)"), ("ivdyn", "ivdyn defaults (its validation)"),
                           ("ivdyn_on_floor_rows", "ivdyn's parameters on the floor's rows")):
            lines.append(f"| {label} | " + " | ".join(f"{x:.3f}" for x in r[key]) + " |")
        lines.append("| ivdyn's Coulomb shape | " + " | ".join(r["coulomb"]) + " |")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--real", help="the real-data root (../shared/data/real)")
    ap.add_argument("--urdf")
    ap.add_argument("--log")
    ap.add_argument("--base")
    ap.add_argument("--tip")
    ap.add_argument("--markdown")
    ap.add_argument("--json")
    a = ap.parse_args()
    results = []
    if a.real:
        results += kuka(a.real) + tx40(a.real)
    if a.urdf and a.log:
        results += generic(a.urdf, a.log, a.base, a.tip)
    if not results:
        ap.error("give --real DIR or --urdf and --log")
    text = table(results)
    print(text)
    if a.markdown:
        with open(a.markdown, "w") as f:
            f.write(text)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
