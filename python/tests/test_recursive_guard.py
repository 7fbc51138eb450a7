"""Issue 16 item 5 from Python: the recursive estimators' anti-windup bound, forgetting
with a direction that is never excited, absurd rows and the outlier gate."""

import numpy as np
import pytest

import ivdyn


def rows(rng, m, unexcited=1):
    """``(m, 3)`` rows uniform on [-1, 1] with column ``unexcited`` zero."""
    Phi = rng.uniform(-1.0, 1.0, size=(m, 3))
    Phi[:, unexcited] = 0.0
    return Phi


def test_defaults_and_options():
    r = ivdyn.Rls(3, p0=50.0, forgetting=0.99)
    assert r.max_variance == 50.0 and r.outlier_gate == np.inf
    r = ivdyn.Rls(3, max_variance=7.0, outlier_gate=5.0)
    assert (r.max_variance, r.outlier_gate) == (7.0, 5.0)
    v = ivdyn.Riv(3, p0=20.0, forgetting=0.9, max_variance=3.0)
    assert (v.max_variance, v.outlier_gate) == (3.0, np.inf)
    assert "max_variance=3" in repr(v)


@pytest.mark.parametrize("cls", [ivdyn.Rls, ivdyn.Riv])
def test_bad_options_name_themselves(cls):
    for bad in [0.0, -1.0, np.nan, np.inf]:
        with pytest.raises(ValueError, match="max_variance.*finite and > 0"):
            cls(3, max_variance=bad)
    for bad in [0.0, -2.0, np.nan]:
        with pytest.raises(ValueError, match="outlier_gate.*> 0"):
            cls(3, outlier_gate=bad)


def test_filed_defect_stays_finite_and_keeps_the_prior():
    # lambda = 0.99 from p0 = 1e4 used to overflow after 69,707 rows; 200,000 here.
    # Directional forgetting never touches the unexcited parameter: variance p0, estimate 0.
    rng = np.random.default_rng(5)
    truth = np.array([0.7, -0.4, 1.3])
    r = ivdyn.Rls(3, p0=1e4, forgetting=0.99)
    Phi = rows(rng, 200_000)
    y = Phi @ truth + 0.01 * rng.standard_normal(200_000)
    r.update_many(Phi, y, np.full(200_000, 1e4))
    P = r.covariance
    assert r.count == 200_000 and np.all(np.isfinite(P))
    np.linalg.cholesky(P)
    assert abs(P[1, 1] - 1e4) <= 1e-12 * 1e4 and r.theta[1] == 0.0
    # excited parameters within 6 standard deviations of the steady state (see the Rust
    # test estim_windup.rs: variance (1 - lambda) / (2 w var(phi)) / 2 = 7.5e-7)
    assert np.all(np.abs(r.theta[[0, 2]] - truth[[0, 2]]) < 6 * np.sqrt(7.5e-7))


def test_riv_cap_keeps_unexcited_direction_at_the_prior():
    rng = np.random.default_rng(6)
    truth = np.array([0.7, -0.4, 1.3])
    v = ivdyn.Riv(3, p0=1e4, forgetting=0.99)
    Z = rows(rng, 100_000)
    v.update_many(Z, Z, Z @ truth)
    P = v.P
    assert np.all(np.isfinite(P)) and np.all(np.abs(np.diag(P)) <= 1e4 * (1 + 1e-15))
    assert v.theta[1] == 0.0


@pytest.mark.parametrize("w", [1e300, 1.0])
def test_absurd_row_is_refused_and_leaves_no_trace(w):
    rng = np.random.default_rng(7)
    truth = np.array([0.7, -0.4, 1.3])
    r = ivdyn.Rls(3, p0=1e12, forgetting=0.99)
    Phi = rng.uniform(-1.0, 1.0, size=(300, 3))
    r.update_many(Phi[:100], Phi[:100] @ truth)
    theta, P = r.theta, r.covariance
    with pytest.raises(ValueError, match="row out of range"):
        r.update(np.full(3, 1e150), 1.0, w)
    assert np.array_equal(r.theta, theta) and np.array_equal(r.covariance, P) and r.count == 100
    bad = np.vstack([Phi[100:200], np.full((1, 3), 1e150)])
    with pytest.raises(ValueError, match="sample 100: row out of range"):
        r.update_many(bad, bad @ truth, np.r_[np.ones(100), w])
    assert r.count == 200
    r.update_many(Phi[200:], Phi[200:] @ truth)
    # noise-free rows: only the prior's pull ~ |truth| / (p0 * information) remains
    assert np.linalg.norm(r.theta - truth) < 1e-10
    v = ivdyn.Riv(3)
    with pytest.raises(ValueError, match="row out of range"):
        v.update(np.full(3, 1e150), np.full(3, 1e150), 1.0, w)
    assert v.count == 0


def test_outlier_gate():
    rng = np.random.default_rng(8)
    truth = np.array([0.7, -0.4, 1.3])
    r = ivdyn.Rls(3, outlier_gate=6.0)
    Phi = rng.uniform(-1.0, 1.0, size=(1000, 3))
    r.update_many(Phi, Phi @ truth + 0.01 * rng.standard_normal(1000), np.full(1000, 1e4))
    phi = np.array([0.5, -0.5, 0.5])
    with pytest.raises(ValueError, match="outlier row: normalised innovation .* exceeds outlier_gate 6"):
        r.update(phi, phi @ truth + 10.0, 1e4)
    r.update(phi, phi @ truth, 1e4)
    assert r.count == 1001
