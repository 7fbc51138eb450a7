#!/usr/bin/env python3
"""SINDy-style baseline for the model-gap diagnosis (issue 15, item 4), scored beside `ivdyn
diagnose` on the same cases with the same rules.

The baseline is sparse regression on the residual of the nominal model: per joint, sequentially
thresholded least squares (STLSQ, Brunton et al. 2016) of `r = tau - rnea_nominal(q, qd, qdd)` over

* the diagnosis's own dictionary (docs/diagnose.md, "Dictionary"), recomputed here in NumPy from
  the log with the NumPy reference (python/reference/ivdyn_ref, written from the equations: the
  deliberate twin of the Rust code): `1` (torque_offset), `q - mean(q)` (joint_spring), `qd`
  (viscous_friction), `sign(qd)` (coulomb_friction), `qdd` (armature), the Stribeck shapes
  `exp(-(qd/vs)^2) sign(qd)` on the same `vs` grid (stribeck_friction), the real drives' columns
  (`[qd > 0]`: asymmetric_coulomb_friction; `tanh(qd/vs)` on the same grid:
  smooth_coulomb_friction; `|tau_nom| sign(qd)`: load_dependent_friction; `tau_nom`: torque_gain;
  `-d tau_nom/dt`: time_delay; `sin(n q)`, `cos(n q)` for n = 4, 6, 8, 12, 16: torque_ripple,
  `tau_nom` the joint's nominal rigid-body torque), the terminal link's 10
  regressor columns (payload) and, as rigid-body corrections that name nothing, each other link's
  torque split into its mass, first-moment and rotational-inertia parts (the re-fit's columns);
* generic terms of the joint's own q, qd, qdd: q^2, qd^2, qdd^2, q qd, q qdd, qd qdd, qd^3,
  qd |qd|, sin q, cos q, sin 2q, cos 2q, and dt qddd (a shift of the acceleration by a sample:
  the torque-to-motion alignment ivdyn fits, here per joint on the joint's own jerk; without
  it a simulator's half-sample lag reads as viscous friction). These name nothing.

Columns are scaled to unit RMS, so a coefficient is the RMS torque its term adds; STLSQ drops
every term below `lambda` noise standard deviations (the joint's noise: MAD of the differences two
samples apart of the least-squares residual, as ivdyn estimates it), refits, and repeats. An effect
is named on a joint when one of its columns survives (a payload: on any joint; Stribeck, smooth and
direction-dependent friction replace Coulomb friction on its joint, Stribeck the smooth one; a spring
contains the offset). Own NumPy code, not PySINDy: PySINDy fits
x_dot = f(x) with one feature library for all targets; a per-joint dictionary with fixed,
log-dependent columns (the regressor) is 30 lines of STLSQ either way, without a dependency.

Conditioning: the log's velocity (else positions differentiated), a zero-phase 2nd-order
Butterworth low-pass at 20 Hz (ivdyn identify's default) run forward and backward, central
differences, 2 filter time constants dropped at both ends.

`lambda` and the ridge (grids below) are chosen on the tuning part of split.json: the most cases
named exactly right, ties broken by the fewest extra (effect, joint) pairs, then the median final /
oracle RMS. Every lambda of the grid is printed, so the choice is visible. The held-out part
(`--part heldout`) is run with the one setting chosen on the tuning part, given as a single
`--lambdas` and `--ridges` value: it never chooses. Scoring (named right, false alarms, final / oracle
RMS) is python/tools/score_diagnose_cases.py's: a case is right when the named (effect, joint)
pairs are the true ones, a true pair below the noise (`split_truth`) named or not.

    python python/tools/sindy_baseline.py /tmp/cad_cases --part tune --bin target/release/ivdyn
    python python/tools/sindy_baseline.py /tmp/cad_cases --part heldout --lambdas L --ridges R --bin ...
"""
import argparse
import hashlib
import json
import os
import statistics
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "reference"))
import score_diagnose_cases as sdc  # noqa: E402
from ivdyn_ref import dynamics as ref_dyn  # noqa: E402
from ivdyn_ref import model as ref_model  # noqa: E402

CUTOFF_HZ = 20.0
STRIBECK_VS = [0.02, 0.05, 0.1, 0.2, 0.4]  # fractions of the joint's RMS speed, as dictionary.rs
SMOOTH_VS = [0.15, 0.2, 0.3, 0.4, 0.6]      # tanh(qd / vs), the same fractions as dictionary.rs
RIPPLE_N = [4.0, 6.0, 8.0, 12.0, 16.0]      # sin(n q), cos(n q), as dictionary.rs
LINK_GROUPS = [(0, 1), (1, 4), (4, 10)]     # mass, first moment, rotational inertia
LAMBDAS = [0.5, 1.0, 2.0, 3.0, 5.0, 10.0, 20.0]
RIDGES = [0.0, 1e-3, 1e-2, 1e-1]


def read_log(path, names, topic="/joint_states"):
    """t, q, qd (None when the log has no velocity), tau of a JointState MCAP log, joints in `names` order."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    rows = []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, _, _, ros in reader.iter_decoded_messages(topics=[topic]):
            idx = [list(ros.name).index(n) for n in names]
            stamp = ros.header.stamp.sec + 1e-9 * ros.header.stamp.nanosec
            vel = [ros.velocity[i] for i in idx] if len(ros.velocity) else None
            rows.append((stamp, [ros.position[i] for i in idx], vel, [ros.effort[i] for i in idx]))
    rows.sort(key=lambda r: r[0])
    t = np.array([r[0] for r in rows])
    q = np.array([r[1] for r in rows])
    qd = None if any(r[2] is None for r in rows) else np.array([r[2] for r in rows])
    tau = np.array([r[3] for r in rows])
    return t - t[0], q, qd, tau


def lowpass(x, fs, fc):
    """Zero-phase low-pass: a 2nd-order Butterworth (bilinear transform) forward and backward."""
    k = np.tan(np.pi * fc / fs)
    norm = 1.0 / (1.0 + np.sqrt(2.0) * k + k * k)
    b0 = k * k * norm
    b1, b2 = 2.0 * b0, b0
    a1, a2 = 2.0 * (k * k - 1.0) * norm, (1.0 - np.sqrt(2.0) * k + k * k) * norm

    def once(x):
        y = np.empty_like(x)
        x1 = x2 = y1 = y2 = x[0]  # start at rest at the first value (no step transient)
        for i in range(len(x)):
            y0 = b0 * x[i] + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2
            x2, x1, y2, y1 = x1, x[i], y1, y0
            y[i] = y0
        return y

    return once(once(x)[::-1])[::-1]


def conditioned(t, q, qd, fc=CUTOFF_HZ):
    """q, qd, qdd, qddd with the filter's edges dropped (module docs)."""
    dt = float(np.median(np.diff(t)))
    fs = 1.0 / dt
    qf = lowpass(q, fs, fc)
    v = lowpass(qd, fs, fc) if qd is not None else np.gradient(qf, dt, axis=0)
    qdd = np.gradient(v, dt, axis=0)
    qddd = np.gradient(qdd, dt, axis=0)
    edge = int(np.ceil(2.0 * fs / (2.0 * np.pi * fc))) + 2
    keep = slice(edge, len(t) - edge)
    return dt, keep, q[keep], v[keep], qdd[keep], qddd[keep]


def drive_columns(x, v, tau_nom, dt, vrms):
    """The real-drive columns of one joint, as dictionary.rs's: `[qd > 0]` (with `sign(qd)`,
    direction-dependent Coulomb friction), `tanh(qd / vs)`, `|tau_nom| sign(qd)` (load-dependent
    friction), `tau_nom` (a torque gain), `-d tau_nom / dt` (a delay, first order) and the ripple
    harmonics of q."""
    c = [("[qd>0]", "asymmetric_coulomb_friction", (v > 0).astype(float))]
    c += [(f"tanh vs={f}", "smooth_coulomb_friction", np.tanh(v / (f * vrms))) for f in SMOOTH_VS]
    c += [("|tau_nom| sign(qd)", "load_dependent_friction", np.abs(tau_nom) * np.sign(v)),
          ("tau_nom", "torque_gain", tau_nom), ("-d tau_nom/dt", "time_delay", -np.gradient(tau_nom, dt))]
    for h in RIPPLE_N:
        c += [(f"sin {h:g}q", "torque_ripple", np.sin(h * x)), (f"cos {h:g}q", "torque_ripple", np.cos(h * x))]
    return c


def dictionary(model, q, qd, qdd, qddd, dt, tau):
    """The nominal residual (T x N) and per joint the dictionary columns: a list of (name, effect or
    None, column)."""
    n = model.n
    links = np.asarray(model.links, float)
    theta = np.concatenate([links.ravel(), np.asarray(model.drive, float).ravel()])
    T = len(q)
    Y = np.empty((T, n, 14 * n))
    for k in range(T):
        Y[k] = ref_dyn.regressor(model, q[k], qd[k], qdd[k])
    tau_nom = Y @ theta
    r = tau - tau_nom
    cols = []
    for j in range(n):
        x, v, a = q[:, j], qd[:, j], qdd[:, j]
        sg = np.sign(v)
        c = [("1", "torque_offset", np.ones(T)), ("q", "joint_spring", x - x.mean()),
             ("qd", "viscous_friction", v), ("sign(qd)", "coulomb_friction", sg), ("qdd", "armature", a)]
        vrms = max(np.sqrt(np.mean(v ** 2)), 1e-9)
        c += [(f"stribeck vs={f}", "stribeck_friction", np.exp(-(v / (f * vrms)) ** 2) * sg) for f in STRIBECK_VS]
        c += drive_columns(x, v, tau_nom[:, j], dt, vrms)
        c += [(f"payload {i}", "payload", Y[:, j, 10 * (n - 1) + i]) for i in range(10)]
        for i in range(n - 1):
            for g, (lo, hi) in enumerate(LINK_GROUPS):
                c.append((f"link {i} part {g}", None, Y[:, j, 10 * i + lo:10 * i + hi] @ links[i, lo:hi]))
        c += [("q^2", None, x * x), ("qd^2", None, v * v), ("qdd^2", None, a * a), ("q qd", None, x * v),
              ("q qdd", None, x * a), ("qd qdd", None, v * a), ("qd^3", None, v ** 3), ("qd|qd|", None, v * abs(v)),
              ("sin q", None, np.sin(x)), ("cos q", None, np.cos(x)), ("sin 2q", None, np.sin(2 * x)),
              ("cos 2q", None, np.cos(2 * x)), ("dt qddd", None, dt * qddd[:, j])]
        cols.append(c)
    return r, cols


def noise_std(res):
    """Noise std from differences two samples apart (MAD), as ivdyn's residual.rs (NOISE_LAG)."""
    d = res[2:] - res[:-2]
    return max(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2.0), 1e-12)


def stlsq(G, b, lam, ridge=0.0, iters=20):
    """Sequentially thresholded (ridge) least squares on unit-RMS columns, as PySINDy's STLSQ, from
    the normal equations (G = X^T X / T, b = X^T y / T): coefficients (in the columns' own scale)
    with every term adding less than `lam` RMS torque dropped; `ridge` is relative to the unit
    diagonal of the scaled normal equations."""
    s = np.sqrt(np.maximum(np.diag(G), 0.0))
    active = s > 0
    inv = np.where(active, 1.0 / np.where(active, s, 1.0), 0.0)
    Gn, bn = G * np.outer(inv, inv), b * inv
    xi = np.zeros(len(b))
    for _ in range(iters):
        idx = np.flatnonzero(active)
        xi[:] = 0.0
        if len(idx):
            A = Gn[np.ix_(idx, idx)] + ridge * np.eye(len(idx))
            # ridge 0: collinear columns get the minimum-norm solution
            xi[idx] = np.linalg.lstsq(A, bn[idx], rcond=None)[0]
        small = active & (np.abs(xi) < lam)
        if not small.any():
            break
        active &= ~small
    xi[~active] = 0.0
    return xi * inv, active


class Prepared:
    """One case's residual, dictionary and noise: everything but the threshold (cached in
    `cache` as .npz when given: the NumPy regressor is the slow part)."""

    def __init__(self, case, manifest, root, cache=None):
        # keyed by the log's absolute path (sets share robot and case names); v2: with the
        # real-drive columns (a v1 file, without them, is not read)
        key = hashlib.sha1(os.path.abspath(os.path.join(root, case["log"])).encode()).hexdigest()[:16]
        path = os.path.join(cache, f"{os.path.basename(root)}_{case['name']}_{key}_v2.npz") if cache else None
        if path and os.path.exists(path):
            z = np.load(path, allow_pickle=False)
            self.names, self.r, self.sigma = list(manifest["joints"]), z["r"], list(z["sigma"])
            self.X = [z[f"X{j}"] for j in range(len(self.names))]
            self.kinds = [list(z[f"k{j}"]) for j in range(len(self.names))]
            return
        self._compute(case, manifest, root)
        if path:
            np.savez(path, r=self.r, sigma=np.array(self.sigma), **{f"X{j}": x for j, x in enumerate(self.X)},
                     **{f"k{j}": np.array(k) for j, k in enumerate(self.kinds)})

    def _compute(self, case, manifest, root):
        names = manifest["joints"]
        urdf = case["urdf"] if os.path.isabs(case["urdf"]) else os.path.join(sdc_root(), case["urdf"])
        model = ref_model.from_urdf(urdf, manifest["base"], manifest["tip"])
        t, q, qd, tau = read_log(os.path.join(root, case["log"]), names, manifest.get("topic", "/joint_states"))
        dt, keep, q, v, a, j3 = conditioned(t, q, qd)
        self.r, self.cols = dictionary(model, q, v, a, j3, dt, tau[keep])
        self.names = names
        self.X = [np.column_stack([c[2] for c in cols]) for cols in self.cols]
        self.kinds = [[c[1] or "" for c in cols] for cols in self.cols]
        self.sigma = []
        for j in range(len(names)):
            full = self.r[:, j] - self.X[j] @ np.linalg.lstsq(self.X[j], self.r[:, j], rcond=None)[0]
            self.sigma.append(noise_std(full))

    def run(self, lam, ridge):
        """diagnosis.json-like {effects, final_rms} for threshold `lam` (noise std) and `ridge`."""
        named = {}
        final = []
        if not hasattr(self, "G"):
            T = len(self.r)
            self.G = [x.T @ x / T for x in self.X]
            self.b = [x.T @ self.r[:, j] / T for j, x in enumerate(self.X)]
        for j, name in enumerate(self.names):
            coef, active = stlsq(self.G[j], self.b[j], lam * self.sigma[j], ridge)
            final.append(float(np.sqrt(np.mean((self.r[:, j] - self.X[j] @ coef) ** 2))))
            kinds = {k for k, a in zip(self.kinds[j], active) if a and k}
            # one name per friction on a joint, the most specific, as the diagnosis reports it
            if kinds & {"stribeck_friction", "smooth_coulomb_friction", "asymmetric_coulomb_friction"}:
                kinds.discard("coulomb_friction")
            if "stribeck_friction" in kinds:
                kinds.discard("smooth_coulomb_friction")
            if "joint_spring" in kinds:
                kinds.discard("torque_offset")
            for k in kinds:
                named.setdefault(k, []).append(name)
        effects = [{"name": k, "joints": [] if k == "payload" else js} for k, js in named.items()]
        return {"effects": effects, "final_rms": final}


def sdc_root():
    return os.path.abspath(os.path.join(HERE, "..", ".."))


def score(results, cases, manifests):
    """Summary of diagnosis.json-like results against the cases' truth (score_diagnose_cases.py's
    rules: a true pair below the noise may be named or not)."""
    right, clean_fa, clean, found, true_pairs, extra, ratios, ratios_true = 0, 0, 0, 0, 0, 0, [], []
    for d, case, m in zip(results, cases, manifests):
        required, optional = sdc.split_truth(case, m)
        truth = required | optional
        true_pairs += len(required)
        if d is None:
            continue
        named = sdc.pairs(d["effects"])
        right += sdc.named_right(named, required, optional)
        found += len(named & required)
        extra += len(named - truth)
        if not truth:
            clean += 1
            clean_fa += bool(named)
        ratios.append(max(a / b for a, b in zip(d["final_rms"], case["oracle"]["oracle_rms_exact"])))
        ratios_true.append(max(a / b for a, b in zip(d["final_rms"], case["oracle"]["oracle_rms_true_model"])))
    med = (lambda x: statistics.median(x) if x else float("nan"))
    return {"right": right, "cases": len(cases), "false_alarm": clean_fa, "clean": clean, "found": found,
            "true_pairs": true_pairs, "extra": extra, "ratio": med(ratios), "ratio_true": med(ratios_true)}


def row(method, s):
    return (f"| {method} | {s['right']} of {s['cases']} | {s['false_alarm']} of {s['clean']} | "
            f"{s['found']} of {s['true_pairs']} | {s['extra']} | {s['ratio']:.2f} | {s['ratio_true']:.2f} |")


def load_cases(root, part):
    with open(os.path.join(root, "split.json")) as f:
        split = json.load(f)
    manifests, out = {}, []
    for cid in split[part]:
        robot, name = cid.split("/")
        if robot not in manifests:
            with open(os.path.join(root, robot, "cases.json")) as f:
                manifests[robot] = json.load(f)
            manifests[robot]["_dir"] = os.path.join(root, robot)
        m = manifests[robot]
        out.append((cid, m, next(c for c in m["cases"] if c["name"] == name)))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("root", help="directory written by make_cad_cases.py (split.json, <robot>/cases.json)")
    ap.add_argument("--part", choices=["tune", "heldout"], default="tune",
                    help="heldout: the setting chosen on the tuning part only (one --lambdas, one --ridges)")
    ap.add_argument("--bin", default=os.environ.get("IVDYN_BIN", "target/release/ivdyn"),
                    help="the ivdyn binary scored beside the baseline (skipped when missing)")
    ap.add_argument("--lambdas", default=",".join(str(x) for x in LAMBDAS),
                    help="STLSQ thresholds tried, in noise standard deviations of RMS torque")
    ap.add_argument("--cache", default=None, help="directory for the prepared dictionaries (.npz)")
    ap.add_argument("--prepare-only", default=None, metavar="I/K",
                    help="only fill --cache for every K-th case from the I-th (parallel preparation)")
    ap.add_argument("--ridges", default=",".join(str(x) for x in RIDGES),
                    help="ridges tried (relative to the unit diagonal of the normal equations)")
    args = ap.parse_args(argv)
    grid = [(float(x), float(y)) for x in args.lambdas.split(",") for y in args.ridges.split(",")]
    if args.part == "heldout" and len(grid) != 1:
        ap.error("--part heldout takes the setting chosen on the tuning part: one --lambdas and one --ridges "
                 f"value (got {len(grid)} settings)")
    cases = load_cases(args.root, args.part)
    if args.prepare_only:
        i, k = (int(x) for x in args.prepare_only.split("/"))
        for cid, m, case in cases[i::k]:
            Prepared(case, m, m["_dir"], args.cache)
            print(f"{cid}: prepared", file=sys.stderr)
        return 0
    per_lam = {g: [] for g in grid}
    ivdyn = []
    have_bin = os.path.exists(args.bin)
    with tempfile.TemporaryDirectory() as tmp:
        for cid, m, case in cases:
            p = Prepared(case, m, m["_dir"], args.cache)
            for g in grid:
                per_lam[g].append(p.run(*g))
            if have_bin:
                d, _, err = sdc.run_case(args.bin, m, case, os.path.join(tmp, cid.split("/")[0]))
                ivdyn.append(d)
            print(f"{cid}: done", file=sys.stderr)
    plain = [c for _, _, c in cases]
    mans = [m for _, m, _ in cases]
    print("| STLSQ threshold (noise std), ridge | exactly right | false alarms | pairs found | extra pairs | "
          "median final/oracle | median final/true-model oracle |")
    print("|---|---|---|---|---|---|---|")
    summaries = {g: score(per_lam[g], plain, mans) for g in grid}
    for g in grid:
        print(row(f"lambda {g[0]:g}, ridge {g[1]:g}", summaries[g]))
    best = max(grid, key=lambda g: (summaries[g]["right"], -summaries[g]["extra"], -summaries[g]["ratio"]))
    if args.part == "tune":
        print(f"\nchosen on these (tuning) cases: lambda = {best[0]:g} noise std, ridge {best[1]:g}\n")
    else:
        print(f"\nheld-out part, the tuning part's setting: lambda = {best[0]:g} noise std, ridge {best[1]:g}\n")
    print("| case | truth | ivdyn diagnose | SINDy baseline |")
    print("|---|---|---|---|")
    for i, (cid, _, case) in enumerate(cases):
        iv = sdc.short(sdc.pairs(ivdyn[i]["effects"])) if have_bin and ivdyn[i] else ("ERROR" if have_bin else "")
        print(f"| {cid} | {sdc.short(sdc.pairs(case['effects']))} | {iv} | "
              f"{sdc.short(sdc.pairs(per_lam[best][i]['effects']))} |")
    print("\n| method | exactly right | false alarms on effect-free logs | true (effect, joint) pairs named | "
          "extra pairs named | median worst-joint final / oracle | median final / true-model oracle |")
    print("|---|---|---|---|---|---|---|")
    if have_bin:
        print(row("ivdyn diagnose", score(ivdyn, plain, mans)))
    print(row(f"SINDy baseline (STLSQ, lambda {best[0]:g}, ridge {best[1]:g})", summaries[best]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
