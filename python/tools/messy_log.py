"""A messy-log generator: what a real recording does to a clean simulated one.

From the same simulated motion (``ivdyn.simulate`` of the true model, friction, torque
noise, a 16-bit encoder, the exact velocity) it makes:

* ``clean``: uniform samples at ``rate`` Hz, effort as torque;
* ``messy``: the same motion sampled at jittered instants (intervals ``U(0.7, 1.3)``
  times the nominal one, 3 % of them up to 9 times longer), about 6 % of the samples
  repeating the previous message (q, qd, effort) under the new stamp, 2 s of standstill at
  both ends, a 0.5 s gap, and the effort as motor current ``i = tau / k_t`` with the
  torque constants given to ivdyn 10 % off (alternately +10 % and -10 % per joint).

Both are dicts of arrays (``t, q, qd`` and ``tau`` or ``current``) that
``ivdyn.identify`` takes. ``make messy`` (``python python/tools/messy_log.py``) prints the comparison of
identify's validation RMS on both variants (100 Hz and 1 kHz); the test
``python/tests/test_messy_logs.py`` asserts it.
"""

import numpy as np

import ivdyn

HOLD_S = 2.0
RAMP_S = 1.0
GAP_S = 0.5
REPEAT_SHARE = 0.06
KT_TRUE = np.array([8.0, 8.0, 6.0, 2.0, 2.0, 1.0])  # N m / A, joint side
KT_ERROR = np.array([1.1, 0.9, 1.1, 0.9, 1.1, 0.9])  # what the user believes / truth
FC = [2.0, 2.0, 1.5, 0.6, 0.6, 0.4]
FV = [0.8, 0.8, 0.5, 0.2, 0.2, 0.1]


def _motion(robot, duration, fine_rate, seed):
    """The true motion on a fine uniform grid: a Fourier excitation faded in and out of
    standstills of HOLD_S at both ends (smoothstep over RAMP_S), and its simulated log."""
    base = ivdyn.simulate(robot, duration=duration, rate=fine_rate, seed=seed)["log"]
    qf = base["q"]
    dt = 1.0 / fine_rate
    hold = int(round(HOLD_S * fine_rate))
    t = np.arange(len(qf) + 2 * hold) * dt
    c = qf.mean(axis=0)
    s = np.clip((t - HOLD_S) / RAMP_S, 0.0, 1.0) * np.clip((t[-1] - HOLD_S - t) / RAMP_S, 0.0, 1.0)
    w = (s * s * (3.0 - 2.0 * s))[:, None]
    qpad = np.vstack([np.repeat(qf[:1], hold, axis=0), qf, np.repeat(qf[-1:], hold, axis=0)])
    q = c + w * (qpad - c)
    return ivdyn.simulate(robot, traj={"t": t, "q": q}, seed=seed, fc=FC, fv=FV, noise=0.05, encoder_bits=16)["log"]


def _sample(fine, times):
    """The fine log linearly interpolated at `times` (every signal)."""
    out = {"t": times}
    for key in ("q", "qd", "tau"):
        x = fine[key]
        out[key] = np.stack([np.interp(times, fine["t"], x[:, j]) for j in range(x.shape[1])], axis=1)
    return out


def _jittered_times(t_end, dt, rng):
    n = int(t_end / dt * 1.2) + 10
    steps = dt * rng.uniform(0.7, 1.3, n)
    long = rng.random(n) < 0.03
    steps[long] = dt * rng.uniform(1.3, 9.0, long.sum())
    times = np.cumsum(steps) - steps[0]
    return times[times <= t_end]


def make(robot, rate, seed, duration=30.0):
    """(clean, messy) logs of the same motion at `rate` Hz (see the module docs)."""
    rng = np.random.default_rng(seed)
    fine = _motion(robot, duration, max(4 * rate, 2000.0), seed)
    t_end = fine["t"][-1]
    clean = _sample(fine, np.arange(0.0, t_end, 1.0 / rate))
    messy = _sample(fine, _jittered_times(t_end, 1.0 / rate, rng))
    t = messy["t"]
    # a gap of GAP_S at 40 % of the log
    g0 = 0.4 * t_end
    keep = (t < g0) | (t > g0 + GAP_S)
    messy = {k: v[keep] for k, v in messy.items()}
    # repeated messages: isolated samples copy the previous one's q, qd and effort
    rep = np.flatnonzero(rng.random(len(messy["t"])) < REPEAT_SHARE)
    rep = rep[rep > 0]
    rep = rep[np.concatenate([[True], np.diff(rep) > 1])]
    for key in ("q", "qd", "tau"):
        messy[key][rep] = messy[key][rep - 1]
    messy["current"] = messy.pop("tau") / KT_TRUE
    return clean, messy, len(rep)


def kt_given():
    """The torque constants the user gives for the messy log (10 % off)."""
    return list(KT_TRUE * KT_ERROR)


def compare(robot, rate, seed):
    """Validation RMS per joint of identify on the clean log and on the messy log, both
    validated on the same independent clean log (seed + 100): the messy log with the true
    torque constants (`messy`), and, in its own units on an independent messy log, with the
    constants 10 % off (`messy_kt_off`: a per-joint scale error the rigid-body model cannot
    absorb, since its parameters are shared by the joints)."""
    clean, messy, repeats = make(robot, rate, seed)
    vclean, vmessy, _ = make(robot, rate, seed + 100)
    rc = ivdyn.identify(robot, clean, validate=vclean)
    rm = ivdyn.identify(robot, messy, validate=vclean, torque_constant=list(KT_TRUE))
    rk = ivdyn.identify(robot, messy, validate=vmessy, torque_constant=kt_given())
    return {"rate": rate, "repeats": repeats, "clean": rc["validation"]["rms"], "messy": rm["validation"]["rms"],
            "messy_kt_off": rk["validation"]["rms"], "conditioning": rm["conditioning"], "notes": rm["notes"]}


def main():
    robot = ivdyn.Robot.from_urdf("fixtures/ur5.urdf", "base_link", "tool0")
    for rate in (100.0, 1000.0):
        r = compare(robot, rate, 11)
        ratio = np.mean(r["messy"]) / np.mean(r["clean"])
        off = np.mean(r["messy_kt_off"]) / np.mean(r["clean"])
        print(f"{rate:.0f} Hz: validation RMS messy {np.round(r['messy'], 4)} clean {np.round(r['clean'], 4)} "
              f"mean ratio {ratio:.3f} (k_t 10 % off, own units: {off:.3f}); "
              f"{r['repeats']} repeats injected, found {r['conditioning']['repeated']}, "
              f"gaps {r['conditioning']['gaps']}, velocity {[v['source'] for v in r['conditioning']['velocity']]}")


if __name__ == "__main__":
    main()
