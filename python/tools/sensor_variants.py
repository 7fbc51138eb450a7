"""What a real recording does to a simulated case's sensors (the random-arm cases of
make_cad_cases.py, issue 15 item 5), drawn per case from its own seed:

* `jitter`: the JointState messages stamped at jittered instants (messy_log.jittered_times:
  intervals U(0.7, 1.3) ms, 3 % of them up to 9 ms), the sensors sampling the simulation
  there (make_diagnose_cases.measured), and about 5 % of the messages re-published: an
  isolated sample repeats the previous message's values under its own stamp
  (messy_log.republish);
* `float32`: every value passes through float32, as a driver that publishes single
  precision does; the positions are the encoder's counts times 2 pi / counts (not a power
  of two, so float32 rounds them), the torque keeps the generator's 2^-14 N m quantum
  (already exact in float32 below 512 N m);
* `velocity: false`: the log's velocity field is empty;
* `torque_constant`: the effort field is the motor current `tau / k_t` (A, joint-side torque
  constants U(0.5, 10) N m/A, quantised to 1 mA), read with `--current-topic /joint_states
  --effort current --torque-constant ...` (the constants exact: a wrong one is a
  `torque_gain`).

Any combination may occur; none of them changes the simulation or the oracle (which is
evaluated on the exact states at the log's stamps, before re-publishing).
"""
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_diagnose_cases as mdc  # noqa: E402
import messy_log  # noqa: E402

P_JITTER, P_FLOAT32, P_NO_VELOCITY, P_CURRENT = 0.3, 0.3, 0.25, 0.25
REPUBLISH_SHARE = 0.05
CURRENT_RES = 1e-3          # A
KT_RANGE = (0.5, 10.0)      # N m/A at the joint


def draw(n, rng):
    """The sensor variant of a case with `n` joints (`rng`: the case's own sensor stream)."""
    s = {"jitter": bool(rng.random() < P_JITTER), "float32": bool(rng.random() < P_FLOAT32),
         "velocity": bool(rng.random() >= P_NO_VELOCITY), "torque_constant": None}
    if rng.random() < P_CURRENT:
        s["torque_constant"] = [float(round(v, 3)) for v in rng.uniform(*KT_RANGE, n)]
    return s


def stamps(sensor, duration, dt, rng):
    """The log's sample instants (s from the start) for a jittered log, else None."""
    if not sensor["jitter"]:
        return None
    return messy_log.jittered_times(duration - dt, dt, rng)


def finish(sensor, t, q, qd, tau, rng):
    """The logged (q, qd or None, effort, re-published count) from the measured values at
    stamps `t`: re-publishing, current, float32, velocity dropped, as the variant says."""
    log = {"t": t, "q": np.array(q), "qd": np.array(qd), "tau": np.array(tau)}
    repeats = messy_log.republish(log, ("q", "qd", "tau"), REPUBLISH_SHARE, rng) if sensor["jitter"] else 0
    q, qd, effort = log["q"], log["qd"], log["tau"]
    if sensor["torque_constant"] is not None:
        effort = np.round(effort / np.array(sensor["torque_constant"]) / CURRENT_RES) * CURRENT_RES
    if sensor["float32"]:
        quantum = 2 * math.pi / mdc.ENCODER_COUNTS
        q = (np.round(q / quantum) * quantum).astype(np.float32).astype(np.float64)
        qd = qd.astype(np.float32).astype(np.float64)
        effort = effort.astype(np.float32).astype(np.float64)
    return q, (qd if sensor["velocity"] else None), effort, repeats


def diagnose_args(sensor):
    """The `ivdyn diagnose` options this variant needs (the effort as current)."""
    if sensor["torque_constant"] is None:
        return []
    return ["--current-topic", "/joint_states", "--effort", "current",
            "--torque-constant", ",".join(repr(v) for v in sensor["torque_constant"])]
