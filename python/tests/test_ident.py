"""Identification bindings of the `ivdyn` package against NumPy: batch LS / IV fits,
base parameters on UR5, recursive estimators against their closed forms, log reading
against Python's own MCAP decoder and the CSV text, the paper reproduction, error paths.

Run from the repo root after `pip install .`:  .venv/bin/python -m pytest -q python/tests
"""
import os

import numpy as np
import pytest

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FIXTURES = os.path.join(ROOT, "fixtures")
LOGS = os.path.join(FIXTURES, "logs")
UR5_URDF = os.path.join(FIXTURES, "ur5.urdf")
TOL = 1e-10


def rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape, (a.shape, b.shape)
    return np.linalg.norm(a - b) / max(np.linalg.norm(b), 1.0)


def problem(seed=0, m=500, p=6, noise=0.1):
    rng = np.random.default_rng(seed)
    Phi = rng.normal(size=(m, p)) * rng.uniform(0.5, 5.0, p)
    theta = rng.normal(size=p)
    y = Phi @ theta + noise * rng.normal(size=m)
    w = rng.uniform(0.2, 3.0, m)
    return rng, Phi, y, w


@pytest.fixture(scope="module")
def ur5():
    return ivdyn.Robot.from_urdf(UR5_URDF, base="base_link", tip="tool0")


@pytest.fixture(scope="module")
def ur5_base(ur5):
    return ivdyn.base_params(ur5, samples=100, seed=1)


# ------------------------------------------------------------------ batch fits

@pytest.mark.parametrize("weighted", [False, True])
def test_fit_ls_matches_lstsq(weighted):
    _, Phi, y, w = problem(1)
    w = w if weighted else None
    fit = ivdyn.fit_ls(Phi, y, w)
    sw = np.sqrt(w) if weighted else np.ones(len(y))
    A, b = Phi * sw[:, None], y * sw
    theta, *_ = np.linalg.lstsq(A, b, rcond=None)
    m, p = Phi.shape
    s2 = np.sum((b - A @ theta) ** 2) / (m - p)
    cov = s2 * np.linalg.inv(A.T @ A)
    assert rel(fit.theta, theta) < TOL
    assert abs(fit.sigma2 - s2) / s2 < TOL
    assert rel(fit.covariance, cov) < TOL
    assert rel(fit.std, np.sqrt(np.diag(cov))) < TOL
    assert rel(fit.rel_std_pct, 100 * np.sqrt(np.diag(cov)) / np.abs(theta)) < 1e-8
    assert (fit.rows, fit.rank, fit.unexcited, fit.dwh, fit.theta_ls) == (m, p, [], None, None)
    sv = np.linalg.svd(A, compute_uv=False)
    assert abs(fit.condition_number - sv[0] / sv[-1]) / (sv[0] / sv[-1]) < 1e-8
    assert fit.names == [f"theta[{j}]" for j in range(p)]


def test_fit_iv_matches_numpy():
    rng, Phi, y, w = problem(2)
    Z = Phi + 0.3 * rng.normal(size=Phi.shape)
    fit = ivdyn.fit_iv(Phi, Z, y, w, names=list("abcdef"))
    W = np.diag(w)
    A = Z.T @ W @ Phi
    theta = np.linalg.solve(A, Z.T @ W @ y)
    m, p = Phi.shape
    s2 = np.sum(w * (y - Phi @ theta) ** 2) / (m - p)
    Ai = np.linalg.inv(A)
    cov = s2 * Ai @ (Z.T @ W @ Z) @ Ai.T
    assert rel(fit.theta, theta) < TOL
    assert abs(fit.sigma2 - s2) / s2 < TOL
    assert rel(fit.covariance, cov) < 1e-9
    sw = np.sqrt(w)
    theta_ls, *_ = np.linalg.lstsq(Phi * sw[:, None], y * sw, rcond=None)
    assert rel(fit.theta_ls, theta_ls) < TOL
    assert set(fit.dwh) == {"statistic", "dof", "p_value", "ls_biased"}
    assert fit.dwh["dof"] == p and 0.0 <= fit.dwh["p_value"] <= 1.0
    assert fit.method == "IV" and fit.names == list("abcdef")


def test_fit_iv_detects_biased_ls():
    # regressor measured with noise correlated with the output noise: LS is biased
    rng = np.random.default_rng(3)
    m = 20000
    x = rng.normal(size=(m, 2))
    e = rng.normal(size=m)
    Phi = x + 0.8 * e[:, None]
    y = x @ np.array([1.0, -2.0]) + e
    fit = ivdyn.fit_iv(Phi, x, y)
    assert fit.dwh["ls_biased"] and fit.dwh["p_value"] < 1e-6
    assert np.abs(fit.theta - [1.0, -2.0]).max() < 0.05


def test_fit_report_repr_and_dict():
    _, Phi, y, _ = problem(4)
    fit = ivdyn.fit_iv(Phi, Phi, y, names=[f"p{j}" for j in range(6)])
    text = repr(fit)
    assert text.startswith("IV fit: 500 rows, rank 6/6") and "p5" in text and "Durbin-Wu-Hausman" in text
    d = fit.to_dict()
    assert set(d) >= {"theta", "std", "rel_std_pct", "covariance", "sigma2", "rows", "rank",
                      "condition_number", "unexcited", "dwh", "theta_ls", "names"}
    assert rel(d["theta"], fit.theta) == 0.0 and d["covariance"].shape == (6, 6)
    assert isinstance(fit, ivdyn.FitReport)


def test_fit_long_input_any_layout():
    # 300 000 rows (streamed in chunks); float32, Fortran order and lists are converted
    rng = np.random.default_rng(5)
    Phi = rng.normal(size=(300_000, 4))
    y = Phi @ np.array([1.0, 2.0, 3.0, 4.0]) + 0.01 * rng.normal(size=300_000)
    theta, *_ = np.linalg.lstsq(Phi, y, rcond=None)
    assert rel(ivdyn.fit_ls(Phi, y).theta, theta) < TOL
    assert rel(ivdyn.fit_ls(np.asfortranarray(Phi), y).theta, theta) < TOL
    assert rel(ivdyn.fit_ls(Phi[::2], y[::2]).theta, np.linalg.lstsq(Phi[::2], y[::2], rcond=None)[0]) < TOL
    small = ivdyn.fit_ls([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]], np.array([1, 2, 3], np.float32))
    assert rel(small.theta, [1.0, 2.0]) < TOL


def test_unexcited_column_is_reported():
    _, Phi, y, _ = problem(6)
    Phi[:, 2] = 0.0
    fit = ivdyn.fit_ls(Phi, y, names=list("abcdef"))
    assert fit.unexcited == ["c"] and fit.rank == 5
    assert np.isnan(fit.theta[2]) and np.isnan(fit.covariance[2]).all()
    keep = [0, 1, 3, 4, 5]
    theta, *_ = np.linalg.lstsq(Phi[:, keep], y, rcond=None)
    assert rel(fit.theta[keep], theta) < TOL


def test_fit_errors():
    _, Phi, y, w = problem(7)
    with pytest.raises(ValueError, match=r"Phi must have shape \(M, P\), got \(500,\)"):
        ivdyn.fit_ls(Phi[:, 0], y)
    with pytest.raises(ValueError, match=r"y must have shape \(500,\)"):
        ivdyn.fit_ls(Phi, y[:-1])
    with pytest.raises(ValueError, match=r"w must have shape \(500,\)"):
        ivdyn.fit_ls(Phi, y, w[:3])
    with pytest.raises(ValueError, match="names must have 6 entries"):
        ivdyn.fit_ls(Phi, y, names=["a"])
    with pytest.raises(ValueError, match="Z must have the shape of Phi"):
        ivdyn.fit_iv(Phi, Phi[:, :3], y)
    with pytest.raises(ValueError, match=r"Phi must be an array of real numbers \(int or float\), got dtype <U1"):
        ivdyn.fit_ls([["a", "b"]], [1.0])
    bad = Phi.copy()
    bad[10, 3] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        ivdyn.fit_ls(bad, y)
    with pytest.raises(ValueError, match="non-finite value in w"):
        ivdyn.fit_ls(Phi, y, -w)
    # instruments orthogonal to the regressor: Z^T Phi singular
    Z = np.zeros_like(Phi)
    with pytest.raises(RuntimeError, match="singular"):
        ivdyn.fit_iv(Phi, Z, y)


# ------------------------------------------------------------------ base parameters

def test_base_params_identity_on_ur5(ur5, ur5_base):
    b = ur5_base
    P = ur5.num_params
    B = b.base_count
    assert b.full_cols == P and len(b.names) == B and 0 < B < P
    assert sorted(b.independent + b.dependent) == list(range(P))
    assert set(b.zero_columns) <= set(b.dependent)
    assert b.K.shape == (B, P - B)
    rng = np.random.default_rng(11)
    T = 200
    Q = rng.uniform(-np.pi, np.pi, (T, 6))
    QD, QDD = rng.uniform(-1, 1, (T, 6)), rng.uniform(-2, 2, (T, 6))
    Y = ur5.regressor(Q, QD, QDD)                         # (T, 6, P)
    for theta in (ur5.params, rng.normal(size=P)):
        lhs = Y @ theta
        Yb = b.select(Y)                                  # (T, 6, B)
        assert Yb.shape == (T, 6, B)
        assert rel(Yb @ b.project(theta), lhs) < TOL
        # project matches its definition, one vector or a stack
        tb = theta[b.independent] + b.K @ theta[b.dependent]
        assert rel(b.project(theta), tb) < 1e-14
        assert rel(b.project(np.stack([theta, theta])), np.stack([tb, tb])) < 1e-14
    x = rng.normal(size=B)
    full = b.to_full(x)
    assert full.shape == (P,) and rel(b.project(full), x) < 1e-14
    assert rel(b.select(Y[0, 0]), Y[0, 0, b.independent]) == 0.0
    # deterministic for a seed
    assert ivdyn.base_params(ur5, 100, 1).names == b.names


def test_base_params_fit_recovers_ur5(ur5, ur5_base):
    """Exact torques -> the LS fit on the base regressor returns project(params)."""
    rng = np.random.default_rng(12)
    T = 400
    Q = rng.uniform(-np.pi, np.pi, (T, 6))
    QD, QDD = rng.uniform(-1, 1, (T, 6)), rng.uniform(-2, 2, (T, 6))
    tau = ur5.rnea(Q, QD, QDD)
    Phi = ur5_base.select(ur5.regressor(Q, QD, QDD)).reshape(-1, ur5_base.base_count)
    fit = ivdyn.fit_ls(Phi, tau.ravel(), names=ur5_base.names)
    assert fit.unexcited == []
    assert rel(fit.theta, ur5_base.project(ur5.params)) < 1e-7


def test_base_params_errors(ur5, ur5_base):
    with pytest.raises(ValueError, match="samples"):
        ivdyn.base_params(ur5, samples=2)
    with pytest.raises(ValueError, match=r"theta_full must have shape \(84,\)"):
        ur5_base.project(np.zeros(5))
    with pytest.raises(ValueError, match=r"Y_full must have shape"):
        ur5_base.select(np.zeros((3, 5)))
    with pytest.raises(ValueError, match="theta_base"):
        ur5_base.to_full(np.zeros(3))
    with pytest.raises(TypeError):
        ivdyn.base_params("ur5")


def test_payload_not_identifiable_names_parameters(ur5, ur5_base):
    rng = np.random.default_rng(13)
    Q = rng.uniform(-np.pi, np.pi, (300, 6))
    QD, QDD = rng.uniform(-1, 1, (300, 6)), rng.uniform(-2, 2, (300, 6))
    tau = ur5.rnea(Q, QD, QDD) + 0.01 * rng.normal(size=(300, 6))
    Phi = ur5_base.select(ur5.regressor(Q, QD, QDD)).reshape(-1, ur5_base.base_count)
    fit = ivdyn.fit_ls(Phi, tau.ravel(), names=ur5_base.names)
    names = ur5.param_names
    first = names.index("wrist_3_link.m")
    cols = list(range(first, first + 10))
    with pytest.raises(ValueError, match=r"payload not identifiable from this data: .*wrist_3_link\.m \(in ") as e:
        ivdyn.payload_from_fit(ur5_base, fit, cols, names)
    assert "wrist_3_link.Izz" in str(e.value) or "wrist_3_link.Ixx" in str(e.value)
    with pytest.raises(ValueError, match="cols must have 10 entries"):
        ivdyn.payload_from_fit(ur5_base, fit, cols[:3], names)
    small = ivdyn.fit_ls(Phi[:, :3], tau.ravel())
    with pytest.raises(ValueError, match="base has"):
        ivdyn.payload_from_fit(ur5_base, small, cols, names)


# ------------------------------------------------------------------ recursive estimators

def test_rls_matches_regularised_batch():
    _, Phi, y, w = problem(20, m=300, p=5)
    p0 = 1e4
    r = ivdyn.Rls(5, p0=p0)
    r.update_many(Phi[:200], y[:200], w[:200])
    for i in range(200, 300):
        r.update(Phi[i], y[i], w[i])
    # exact: RLS from theta = 0, P = p0 I is the ridge solution with prior I / p0
    info = Phi.T @ (w[:, None] * Phi) + np.eye(5) / p0
    theta = np.linalg.solve(info, Phi.T @ (w * y))
    assert rel(r.theta, theta) < 1e-9
    assert rel(r.covariance, np.linalg.inv(info)) < 1e-9
    assert r.count == 300 and r.p == 5
    # and close to the batch LS fit
    assert rel(r.theta, ivdyn.fit_ls(Phi, y, w).theta) < 1e-5


def test_rls_forgetting_changes_estimate():
    _, Phi, y, _ = problem(21, m=300, p=3)
    a, b = ivdyn.Rls(3), ivdyn.Rls(3, forgetting=0.95)
    a.update_many(Phi, y)
    b.update_many(Phi, y)
    assert np.all(np.isfinite(b.theta)) and rel(a.theta, b.theta) > 1e-6


def test_riv_matches_batch():
    rng, Phi, y, w = problem(22, m=300, p=4)
    Z = Phi + 0.2 * rng.normal(size=Phi.shape)
    p0 = 1e3
    r = ivdyn.Riv(4, p0=p0)
    r.update_many(Phi[:150], Z[:150], y[:150], w[:150])
    for i in range(150, 300):
        r.update(Phi[i], Z[i], y[i], w[i])
    # exact: P^-1 = I / p0 + sum w z phi^T, P^-1 theta = sum w z y
    info = np.eye(4) / p0 + Z.T @ (w[:, None] * Phi)
    assert rel(r.theta, np.linalg.solve(info, Z.T @ (w * y))) < 1e-9
    assert rel(r.P, np.linalg.inv(info)) < 1e-9
    assert rel(r.theta, ivdyn.fit_iv(Phi, Z, y, w).theta) < 1e-4
    assert r.count == 300


def test_recursive_errors():
    with pytest.raises(ValueError, match=r"p must be in 1\.\.=4096, got 0"):
        ivdyn.Rls(0)
    with pytest.raises(ValueError, match="forgetting"):
        ivdyn.Riv(3, forgetting=1.5)
    with pytest.raises(ValueError, match="p0"):
        ivdyn.Rls(3, p0=-1.0)
    r = ivdyn.Rls(3)
    with pytest.raises(RuntimeError, match="degenerate recursive estimator update"):
        r.update([1.0, 2.0, 3.0], 1.0, w=0.0)
    with pytest.raises(ValueError, match=r"non-finite value in phi\[1\]"):
        r.update([1.0, np.nan, 3.0], 1.0)
    with pytest.raises(ValueError, match=r"phi must have shape \(3,\)"):
        r.update([1.0, 2.0], 1.0)
    assert r.count == 0 and np.all(r.theta == 0)
    Phi = np.ones((5, 3))
    Phi[3, 0] = np.inf
    with pytest.raises(ValueError, match="sample 3: non-finite value in phi"):
        r.update_many(Phi, np.ones(5))
    assert r.count == 3
    with pytest.raises(ValueError, match=r"Phi must have shape \(M, 3\)"):
        r.update_many(np.ones((5, 2)), np.ones(5))
    v = ivdyn.Riv(2)
    # 1/w + phi^T P z = 1e4 - 1e4 = 0: the update is degenerate
    with pytest.raises(RuntimeError, match="degenerate recursive estimator update"):
        v.update([1.0, 0.0], [-1.0, 0.0], 1.0, w=1e-4)
    with pytest.raises(ValueError, match="Z must have the shape of Phi"):
        v.update_many(np.ones((4, 2)), np.ones((3, 2)), np.ones(4))
    assert v.count == 0


# ------------------------------------------------------------------ logs

@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_read_mcap_against_python_decoder(ur5):
    from mcap_ros2.reader import read_ros2_messages

    path = os.path.join(LOGS, "ur5_500hz.mcap")
    log = ivdyn.read_joint_states(path, ur5.joint_names)
    T = len(log["t"])
    assert T == 1000 and log["q"].shape == (T, 6) and log["tau"].shape == (T, 6)
    assert log["qd"] is None and log["u"] is None
    assert log["joint_names"] == ur5.joint_names and not log["truncated"]
    msgs = [m.ros_msg for m in read_ros2_messages(path, topics=["/joint_states"])]
    q = np.array([[m.position[list(m.name).index(j)] for j in ur5.joint_names] for m in msgs])
    tau = np.array([[m.effort[list(m.name).index(j)] for j in ur5.joint_names] for m in msgs])
    stamp = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in msgs])
    assert np.array_equal(log["q"], q) and np.array_equal(log["tau"], tau)
    assert log["t0_ns"] == stamp[0]
    assert np.allclose(log["t"], (stamp - stamp[0]) * 1e-9, atol=1e-12, rtol=0)
    # a robot gives its joint names; the command topic fills u
    log2 = ivdyn.read_joint_states(path, ur5, command_topic="/joint_command")
    assert log2["u"].shape == (T, 6) and np.all(np.isfinite(log2["u"]))


def test_read_csv(ur5):
    path = os.path.join(LOGS, "ur5_short.csv")
    log = ivdyn.read_joint_states(path, ur5.joint_names)
    with open(path) as f:
        lines = [ln.strip() for ln in f if ln.strip() and not ln.startswith("#")]
    header = lines[0].split(",")
    data = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    assert np.array_equal(log["t"], data[:, header.index("t")])
    for j, name in enumerate(ur5.joint_names):
        assert np.array_equal(log["q"][:, j], data[:, header.index(f"{name}.q")])
        assert np.array_equal(log["tau"][:, j], data[:, header.index(f"{name}.tau")])
    assert log["q"].shape == (20, 6) and log["tau"].shape == (20, 6) and log["qd"] is None


def test_read_errors(ur5):
    with pytest.raises(FileNotFoundError):
        ivdyn.read_joint_states(os.path.join(LOGS, "missing.mcap"), ur5.joint_names)
    with pytest.raises(ValueError, match="no_such_joint"):
        ivdyn.read_joint_states(os.path.join(LOGS, "ur5_500hz.mcap"), ["no_such_joint"])
    with pytest.raises(ValueError, match=r"unknown log format: expected a \.mcap, \.db3 or \.csv file or a ROS 2 bag directory"):
        ivdyn.read_joint_states(UR5_URDF, ur5.joint_names)
    with pytest.raises(ValueError, match="/nope"):
        ivdyn.read_joint_states(os.path.join(LOGS, "ur5_500hz.mcap"), ur5.joint_names, topic="/nope")
    with pytest.raises(ValueError, match="elbow_joint"):
        ivdyn.read_joint_states(os.path.join(LOGS, "ur5_nan.mcap"), ur5.joint_names)
    with pytest.raises(ValueError, match="not a string"):
        ivdyn.read_joint_states(os.path.join(LOGS, "ur5_short.csv"), "elbow_joint")


# ------------------------------------------------------------------ paper reproduction

def test_paper_setup():
    sim = ivdyn.paper.setup(0)
    B = len(sim.base_names)
    assert sim.truth_base.shape == (B,) and B == 18
    assert "link6.m*cx" in sim.base_names and "link6.Izz" in sim.base_names
    assert len(sim.full_names) == 24 and sim.accel_noise == 10.0 and sim.dt == 1e-3
    assert len(ivdyn.paper.ESTIMATORS) == 4 and ivdyn.paper.ESTIMATORS[0] == "LSM"


def test_paper_noise_free_recovery():
    sim = ivdyn.paper.setup(0)
    est = ivdyn.paper.batch_estimates(0, 0, [500, 2000], accel_noise=0.0)
    assert est.shape == (4, 2, 18)
    truth = sim.truth_base
    for k in range(4):
        assert np.abs(est[k, -1] - truth).max() < 1e-8 * max(np.abs(truth).max(), 1.0), ivdyn.paper.ESTIMATORS[k]


def test_paper_iv_planned_within_10_percent():
    sim = ivdyn.paper.setup(0)
    est = ivdyn.paper.batch_estimates(0, 1, [20_000])
    b = sim.base_names.index("link6.m*cx")
    k = ivdyn.paper.ESTIMATORS.index("IVM (planned acceleration)")
    truth = sim.truth_base[b]
    assert abs(est[k, 0, b] - truth) < 0.10 * abs(truth)


def test_paper_recursive_traces():
    sim = ivdyn.paper.setup(0, accel_noise=0.0)
    n = ivdyn.paper.log_points(10, 3000, 5)
    assert np.all(np.diff(n) > 0) and n[0] == 10 and n[-1] == 3000
    tr = ivdyn.paper.recursive_traces(0, 0, n, p0=1e6, accel_noise=0.0)
    assert tr.shape == (4, len(n), 18) and np.all(np.isfinite(tr))
    # noise-free data: the recursive estimates approach the truth
    err = np.abs(tr[:, -1] - sim.truth_base).max()
    assert err < 1e-2 * np.abs(sim.truth_base).max()
    assert rel(sim.recursive_traces(0, list(n), 1e6), tr) == 0.0


def test_paper_errors():
    with pytest.raises(ValueError, match="strictly increasing"):
        ivdyn.paper.batch_estimates(0, 0, [2000, 1000])
    with pytest.raises(ValueError, match="strictly increasing"):
        ivdyn.paper.recursive_traces(0, 0, [])
    with pytest.raises(ValueError, match="accel_noise"):
        ivdyn.paper.setup(0, accel_noise=-1.0)


def test_plot_paper_traces(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = ["link6.m*cx", "link6.Izz", "link5.Ixy"]
    n = np.array([10, 100, 1000])
    est = np.random.default_rng(0).normal(size=(2, 3, 3))
    ax = ivdyn.plot.paper_traces(names, [1.0, 2.0, 0.0], n, est, ["LSM", "IVM"], estimator=1, param="link6.Izz")
    assert ax.get_title() == "link6.Izz" and len(ax.get_lines()) == 3
    fig = ivdyn.plot.paper_traces(names, [1.0, 2.0, 0.0], n, est, ["LSM", "IVM"])
    fig.savefig(tmp_path / "grid.png")
    plt.close("all")
    with pytest.raises(ValueError, match="estimates must have shape"):
        ivdyn.plot.paper_traces(names, [1.0, 2.0, 0.0], n, est[:, :2], ["LSM", "IVM"])
    with pytest.raises(ValueError, match="no base parameter named"):
        ivdyn.plot.paper_traces(names, [1.0, 2.0, 0.0], n, est, ["LSM", "IVM"], param="nope")


def test_fit_robot_matches_materialised_regressor_fit():
    """The fused Rust fit equals fitting the stacked regressor with NumPy (lstsq), on a
    noisy UR5 data set; the rigid-only base set of the UR5 has 36 parameters."""
    robot = ivdyn.Robot.from_urdf(os.path.join(FIXTURES, "ur5.urdf"), base="base_link", tip="tool0")
    rng = np.random.default_rng(3)
    T = 3000
    Q, QD, QDD = rng.uniform(-3, 3, (T, 6)), rng.uniform(-1, 1, (T, 6)), rng.uniform(-2, 2, (T, 6))
    tau = robot.rnea(Q, QD, QDD) + 0.05 * rng.standard_normal((T, 6))
    for rigid in (False, True):
        base = ivdyn.base_params(robot, rigid_only=rigid)
        assert base.base_count == (36 if rigid else 58)
        if rigid:
            tau_fit = tau - (robot.rnea(Q, QD, QDD) - robot.regressor(Q, QD, QDD, rigid_only=True) @ robot.params[:60])
        else:
            tau_fit = tau
        fit = ivdyn.fit_robot(robot, base, Q, QD, QDD, tau_fit)
        Y = robot.regressor(Q, QD, QDD, rigid_only=rigid).reshape(-1, base.full_cols)
        Phi = base.select(Y)
        ref, *_ = np.linalg.lstsq(Phi, tau_fit.reshape(-1), rcond=None)
        np.testing.assert_allclose(fit.theta, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
    with pytest.raises(ValueError, match="tau must have shape"):
        ivdyn.fit_robot(robot, base, Q, QD, QDD, tau[:, :5])
