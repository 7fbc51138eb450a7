"""When, within the generator's MuJoCo step, each kind of effect acts (docs/diagnose.md,
"Uncertainty", why a log velocity moved by its lag reads friction at the reversals
differently).

With the semi-implicit Euler step (`make_diagnose_cases.mujoco_model`) the logged `qvel_k` is
the positions' backward difference, `(q_k - q_(k-1)) / dt`: half a sample before their central
difference. MuJoCo's friction-loss constraint, stiff as the generator sets it (`solref` 2 dt,
1), opposes the velocity at the end of the step, `qvel_(k+1)`, half a sample after the
positions' time; the forces the generator applies from the state use `qvel_k`. Asserted on one
hinge driven through its reversals without sticking: the backward difference exactly, and the
constraint force opposing `qvel_(k+1)` at 3 in 4 of the reversal steps or more (measured 43 of
51), `qvel_k` at 1 in 4 or fewer (8 of 51): a change of MuJoCo's step would show here first.
"""
import mujoco
import numpy as np

XML = """<mujoco><option timestep="0.001" integrator="Euler" gravity="0 0 0"/>
<worldbody><body><joint name="j" type="hinge" axis="0 0 1" frictionloss="0.3" solreffriction="0.002 1"/>
<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/></body></worldbody></mujoco>"""


def test_friction_constraint_opposes_the_end_of_step_velocity():
    m = mujoco.MjModel.from_xml_string(XML)
    d = mujoco.MjData(m)
    steps, dt = 20000, m.opt.timestep
    q, qd, f = np.zeros(steps + 1), np.zeros(steps + 1), np.zeros(steps)
    for k in range(steps):
        q[k], qd[k] = d.qpos[0], d.qvel[0]
        t = k * dt
        # two tones, large against the friction: the joint slides through its reversals
        d.qfrc_applied[0] = 3.0 * np.sin(2 * np.pi * 1.3 * t) + np.sin(2 * np.pi * 3.1 * t)
        mujoco.mj_step(m, d)
        f[k] = d.qfrc_constraint[0]
    q[steps], qd[steps] = d.qpos[0], d.qvel[0]
    # semi-implicit Euler: q_k = q_(k-1) + dt qvel_k, the logged velocity a backward difference
    np.testing.assert_allclose(qd[1:], np.diff(q) / dt, rtol=0, atol=1e-9)
    rev = [k for k in range(1, steps) if qd[k] * qd[k + 1] < 0]
    assert len(rev) >= 40, len(rev)
    end = sum(np.sign(f[k]) == -np.sign(qd[k + 1]) for k in rev)
    start = sum(np.sign(f[k]) == -np.sign(qd[k]) for k in rev)
    assert end >= 0.75 * len(rev), (end, start, len(rev))
    assert start <= 0.25 * len(rev), (end, start, len(rev))
