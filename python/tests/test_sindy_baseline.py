"""The SINDy-style baseline's numerics (python/tools/sindy_baseline.py), against theory: STLSQ
keeps exactly the terms a sparse truth has, with least-squares accuracy; the zero-phase
Butterworth run forward and backward has the gain |H|^2 = 1 / (1 + (f/fc)^4) at the warped
frequency of the bilinear transform, and no phase."""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tools"))
import sindy_baseline as sb  # noqa: E402


def test_stlsq_keeps_the_true_terms():
    rng = np.random.default_rng(15)
    T, sigma = 4000, 0.01
    t = np.linspace(0.0, 8.0, T)
    X = np.column_stack([np.sin(2 * t), np.cos(3 * t), t / 8.0, np.sign(np.sin(t)), np.cos(5 * t)])
    truth = np.array([2.0, 0.0, 0.0, 0.5, 0.0])
    y = X @ truth + sigma * rng.standard_normal(T)
    G, b = X.T @ X / T, X.T @ y / T
    coef, active = sb.stlsq(G, b, lam=5 * sigma, ridge=0.0)
    assert list(np.flatnonzero(active)) == [0, 3]
    # least squares on the two kept columns: standard errors sigma / sqrt(T x mean square)
    se = sigma / np.sqrt(T * np.mean(X[:, [0, 3]] ** 2, axis=0))
    assert np.all(np.abs(coef[[0, 3]] - truth[[0, 3]]) < 4 * se), (coef, se)
    # a threshold above every term's RMS keeps nothing
    _, none = sb.stlsq(G, b, lam=10.0, ridge=0.0)
    assert not none.any()


def test_zero_phase_lowpass_gain():
    fs, fc = 1000.0, 20.0
    t = np.arange(4000) / fs
    # bilinear transform: the digital frequency f acts as the analog tan(pi f / fs) / tan(pi fc / fs) x fc
    warp = lambda f: np.tan(np.pi * f / fs) / np.tan(np.pi * fc / fs)  # noqa: E731
    for f in [1.0, 80.0]:
        want = 1.0 / (1.0 + warp(f) ** 4)
        x = np.sin(2 * np.pi * f * t)[:, None]
        y = sb.lowpass(x, fs, fc)[1000:3000, 0]
        gain = np.sqrt(2.0 * np.mean(y ** 2))
        assert abs(gain - want) < 0.01 * want, (f, gain, want)
        # zero phase: the output peaks where the input does
        assert abs(np.dot(y, np.cos(2 * np.pi * f * t[1000:3000]))) < 0.01 * np.dot(y, y) + 1e-9


def test_noise_std_of_white_noise_under_a_slow_signal():
    # MAD of the differences two samples apart: for white noise of std sigma they have std
    # sigma sqrt(2), a slow sine barely moves them. The MAD's relative standard error at
    # n = 20000 is about 1.1 %, so 5 % is beyond four standard errors.
    rng = np.random.default_rng(16)
    T, sigma = 20000, 0.02
    t = np.arange(T) / 1000.0
    r = 1.0 * np.sin(2 * np.pi * 0.1 * t) + sigma * rng.standard_normal(T)
    assert abs(sb.noise_std(r) - sigma) < 0.05 * sigma


def test_heldout_part_takes_the_tuned_setting_only(tmp_path):
    # the held-out part never chooses: a grid of settings is refused before any case is read
    import pytest
    with pytest.raises(SystemExit):
        sb.main([str(tmp_path), "--part", "heldout", "--lambdas", "1,2", "--ridges", "0.001"])


def test_drive_columns_against_their_formulas():
    # q = sin(w t), a nominal torque 2 sin(w t + 0.3): the delay column is -d tau/dt, whose
    # central difference errs by (w dt)^2 / 6 relative (1e-7 here); the other columns are
    # closed forms of q, qd and tau
    dt, w = 1e-3, 2 * np.pi * 0.5
    t = np.arange(4000) * dt
    x, v, tau = np.sin(w * t), w * np.cos(w * t), 2.0 * np.sin(w * t + 0.3)
    cols = {name: (kind, c) for name, kind, c in sb.drive_columns(x, v, tau, dt, np.sqrt(np.mean(v ** 2)))}
    kind, delay = cols["-d tau_nom/dt"]
    assert kind == "time_delay"
    want = -2.0 * w * np.cos(w * t + 0.3)
    assert np.max(np.abs(delay[1:-1] - want[1:-1])) < 1e-5 * 2.0 * w
    np.testing.assert_array_equal(cols["tau_nom"][1], tau)
    np.testing.assert_array_equal(cols["[qd>0]"][1], (v > 0).astype(float))
    np.testing.assert_allclose(cols["|tau_nom| sign(qd)"][1], np.abs(tau) * np.sign(v))
    np.testing.assert_allclose(cols["sin 8q"][1], np.sin(8 * x))
    assert {k for k, _ in cols.values()} == {"asymmetric_coulomb_friction", "smooth_coulomb_friction",
                                             "load_dependent_friction", "torque_gain", "time_delay", "torque_ripple"}
