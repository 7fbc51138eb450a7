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

``make_pair`` records the arm twice, messy, without and with a known payload (``PAYLOAD``;
other seeds, so other trajectories, jitter and noise); ``pair_study`` measures the drive
gains from that pair (truth ``KT_TRUE``, which the user believes ``KT_TRUE * KT_ERROR``),
the payload with those gains (their covariance in its std) and with the believed
constants, and whether the stated std cover the truth. ``make messy`` prints the table of
docs/real-logs.md ("The messy pair"); ``python/tests/test_messy_pair.py`` asserts 100 Hz.
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


def _motion(robot, duration, fine_rate, seed, payload):
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
    return ivdyn.simulate(robot, traj={"t": t, "q": q}, seed=seed, fc=FC, fv=FV, noise=0.05, encoder_bits=16,
                          **payload)["log"]


def _sample(fine, times):
    """The fine log linearly interpolated at `times` (every signal)."""
    out = {"t": times}
    for key in ("q", "qd", "tau"):
        x = fine[key]
        out[key] = np.stack([np.interp(times, fine["t"], x[:, j]) for j in range(x.shape[1])], axis=1)
    return out


def jittered_times(t_end, dt, rng):
    """Sample instants in [0, t_end] of a nominal period `dt`: intervals U(0.7, 1.3) dt, 3 %
    of them U(1.3, 9) dt."""
    n = int(t_end / dt * 1.2) + 10
    steps = dt * rng.uniform(0.7, 1.3, n)
    long = rng.random(n) < 0.03
    steps[long] = dt * rng.uniform(1.3, 9.0, long.sum())
    times = np.cumsum(steps) - steps[0]
    return times[times <= t_end]


def _messify(fine, rate, rng):
    """`fine` sampled at jittered instants of nominal `rate` Hz, with a gap of GAP_S at 40 %
    of the log, isolated repeated messages (q, qd and effort copied from the previous
    sample) and the effort as the current through the true torque constants. Returns the
    log and the number of repeats."""
    t_end = fine["t"][-1]
    messy = _sample(fine, jittered_times(t_end, 1.0 / rate, rng))
    t = messy["t"]
    g0 = 0.4 * t_end
    keep = (t < g0) | (t > g0 + GAP_S)
    messy = {k: v[keep] for k, v in messy.items()}
    repeats = republish(messy, ("q", "qd", "tau"), REPEAT_SHARE, rng)
    messy["current"] = messy.pop("tau") / KT_TRUE
    return messy, repeats


def republish(log, keys, share, rng):
    """About `share` of the samples (isolated ones, never the first) repeat the previous
    message's `keys` under their own stamp, as a driver that re-publishes a stale state does.
    In place; returns how many."""
    rep = np.flatnonzero(rng.random(len(log["t"])) < share)
    rep = rep[rep > 0]
    rep = rep[np.concatenate([[True], np.diff(rep) > 1])]
    for key in keys:
        log[key][rep] = log[key][rep - 1]
    return len(rep)


def make(robot, rate, seed, duration=30.0, payload=None):
    """(clean, messy, repeats) logs of the same motion at `rate` Hz (see the module docs);
    `payload`: ivdyn.simulate's payload_mass/com/inertia keywords (the arm carries it)."""
    rng = np.random.default_rng(seed)
    fine = _motion(robot, duration, max(4 * rate, 2000.0), seed, payload or {})
    clean = _sample(fine, np.arange(0.0, fine["t"][-1], 1.0 / rate))
    messy, repeats = _messify(fine, rate, rng)
    return clean, messy, repeats


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


# --- the loaded/unloaded pair (issue 14): drive gains and the payload from messy currents

PAYLOAD_MASS = 2.0
PAYLOAD_COM = [0.02, -0.03, 0.05]  # m, in tool0's frame
PAYLOAD_INERTIA = [0.006, 0.0, 0.005, 0.0, 0.0, 0.004]  # Ixx, Ixy, Iyy, Ixz, Iyz, Izz about the COM: a rigid body (I1 + I2 > I3)
PAYLOAD = dict(payload_mass=PAYLOAD_MASS, payload_com=PAYLOAD_COM, payload_inertia=PAYLOAD_INERTIA)
KT_STD = 0.1  # the user's relative std of the believed constants (they are 10 % off)
PAIR_SEED = 21
COVERAGE_SEEDS = {100.0: 10, 1000.0: 5}  # `make messy` repeats the pair on this many seeds
COVER = 2.5  # a stated std covers the truth when |error| <= COVER std


def make_pair(robot, rate, seed, duration=30.0):
    """Messy logs of one arm without and then with PAYLOAD, as two recordings: another
    trajectory, jitter, repeats and noise each (seeds `seed` and `seed + 1`). The currents
    are through KT_TRUE, which the user does not know (they believe `kt_given()`)."""
    _, unloaded, _ = make(robot, rate, seed, duration)
    _, loaded, _ = make(robot, rate, seed + 1, duration, payload=PAYLOAD)
    return unloaded, loaded


def _payload_errors(p):
    """Mass and COM errors of a payload report against PAYLOAD, and whether its stated
    std covers them (per quantity: |error| <= COVER std)."""
    dm = p["mass"] - PAYLOAD_MASS
    dc = np.asarray(p["com"]) - PAYLOAD_COM
    cs = np.asarray(p["com_std"])
    return {"mass_err_pct": 100.0 * dm / PAYLOAD_MASS, "com_err_cm": 100.0 * np.linalg.norm(dc),
            "mass_z": abs(dm) / p["mass_std"], "com_z": np.abs(dc) / cs,
            "covered": bool(abs(dm) <= COVER * p["mass_std"] and np.all(np.abs(dc) <= COVER * cs)),
            "sources": p.get("uncertainty_sources")}


def pair_study(robot, rate, seed, duration=30.0):
    """(a) the drive gains from a messy pair with the payload's mass known, against
    KT_TRUE; (b) the payload from the same pair (unloaded as the before log) with the
    estimated gains, and with the believed constants; (c) whether its std covers the truth.
    A gain the pair does not determine takes the believed value, with a KT_STD std."""
    unloaded, loaded = make_pair(robot, rate, seed, duration)
    g = ivdyn.drive_gains(robot, unloaded, loaded, payload_mass=PAYLOAD_MASS)
    ident = [x["identifiable"] for x in g["gains"]]
    est = np.array([x["value"] if ok else np.nan for x, ok in zip(g["gains"], ident)])
    kt = np.where(ident, est, kt_given())
    # the gains as exact (the std cover the noise and the before model only), then with
    # their covariance (and the believed constants, 10 % std, where the pair says nothing)
    exact = ivdyn.payload(robot, loaded, before=unloaded, torque_constant=list(kt))
    with_gains = ivdyn.payload(robot, loaded, before=unloaded, gains=g, torque_constant=kt_given(),
                               torque_constant_std=list(KT_STD * np.array(kt_given())))
    believed = ivdyn.payload(robot, loaded, before=unloaded, torque_constant=kt_given())
    believed_std = ivdyn.payload(robot, loaded, before=unloaded, torque_constant=kt_given(),
                                 torque_constant_std=list(KT_STD * np.array(kt_given())))
    return {"rate": rate, "gain_err_pct": 100.0 * (est - KT_TRUE) / KT_TRUE,
            "gain_rel_std_pct": np.array([x["rel_std_pct"] or np.nan for x in g["gains"]]),
            "identifiable": ident, "not_identifiable": [x["joint"] for x in g["gains"] if not x["identifiable"]],
            "gains_exact": _payload_errors(exact), "with_gains": _payload_errors(with_gains),
            "believed": _payload_errors(believed), "believed_std": _payload_errors(believed_std)}


PAYLOAD_ROWS = [("with_gains", "estimated gains, their covariance in the std"),
                ("gains_exact", "estimated gains taken as exact"),
                ("believed", "believed constants (10 % off) as exact"),
                ("believed_std", "believed constants, 10 % std")]


def pair_table(robot, results):
    """The pair study's numbers as a markdown table, one column per rate."""
    cols = " | ".join(f"{r['rate']:.0f} Hz" for r in results)
    lines = [f"| quantity | {cols} | target |", "|---" * (len(results) + 2) + "|"]

    def row(name, cells, target=""):
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {target} |")

    for j, joint in enumerate(robot.joint_names):
        row(f"gain error {joint} (rel. std), %",
            [f"{r['gain_err_pct'][j]:+.2f} ({r['gain_rel_std_pct'][j]:.2f})" if r["identifiable"][j]
             else f"not identifiable ({r['gain_rel_std_pct'][j]:.1f})" for r in results], "within 2")
    row("gains not identifiable", [", ".join(r["not_identifiable"]) or "none" for r in results], "listed")
    targets = {"with_gains": ("<= 3, <= 1", "covered"), "believed": ("<= 3, <= 1", "")}
    for key, what in PAYLOAD_ROWS:
        t_err, t_z = targets.get(key, ("", ""))
        row(f"payload, {what}: mass error %, COM error cm",
            [f"{r[key]['mass_err_pct']:+.2f}, {r[key]['com_err_cm']:.2f}" for r in results], t_err)
        row(f"payload, {what}: \\|error\\|/std mass; COM x, y, z",
            [f"{r[key]['mass_z']:.2f}; " + ", ".join(f"{z:.2f}" for z in r[key]["com_z"])
             + (" (covered)" if r[key]["covered"] else " (**not covered**)") for r in results], t_z)
    row("payload std cover (estimated gains)", [", ".join(r["with_gains"]["sources"]) for r in results])
    return "\n".join(lines)


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
    print(f"\nloaded/unloaded pair (seed {PAIR_SEED}; {PAYLOAD_MASS} kg at {PAYLOAD_COM} m; k_t true {KT_TRUE.tolist()}, "
          f"believed x{KT_ERROR.tolist()}; covered: |error| <= {COVER} std on mass and every COM axis)\n")
    print(pair_table(robot, [pair_study(robot, rate, PAIR_SEED) for rate in (100.0, 1000.0)]))
    for rate, count in COVERAGE_SEEDS.items():
        print()
        print(seed_summary(robot, rate, range(PAIR_SEED, PAIR_SEED + count)))


def seed_summary(robot, rate, seeds):
    """The pair study over `seeds` at `rate` Hz: the largest errors and how often each
    payload variant's std covered the truth."""
    runs = [pair_study(robot, rate, s) for s in seeds]
    head = f"{rate:.0f} Hz, seeds {seeds.start}-{seeds.stop - 1}"
    err = np.array([np.abs(r["gain_err_pct"]) for r in runs])
    z = err / np.array([r["gain_rel_std_pct"] for r in runs])
    lines = [f"{head}: largest |gain error| per joint {np.nanmax(err, axis=0).round(2)} %, largest "
             f"|error|/std {np.nanmax(z, axis=0).round(1)}; not identifiable: "
             f"{sorted({j for r in runs for j in r['not_identifiable']}) or 'none'}"]
    for key, what in PAYLOAD_ROWS:
        lines.append(f"{head}, payload with {what}: covered in {sum(r[key]['covered'] for r in runs)} of "
                     f"{len(runs)}; |mass error| <= {max(abs(r[key]['mass_err_pct']) for r in runs):.2f} %, "
                     f"COM error <= {max(r[key]['com_err_cm'] for r in runs):.2f} cm")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
