"""The command line's pipelines from Python: :func:`identify`, :func:`payload`,
:func:`drive_gains`, :func:`simulate` run ``ivdyn::app`` (the code behind ``ivdyn identify
/ payload / gains / simulate``) and return the same content as the command's ``--json``
file, as a dict.

Long calls release the GIL and report progress: ``progress=callable(done, total)`` is
called from the pipeline's progress hook (``total`` 0 for a step of unknown length; a
new step starts again from ``done = 0``), ``progress=True`` shows a tqdm bar if tqdm is
installed (nothing otherwise). An exception raised by the callback, or Ctrl-C, stops the
call and is raised from it.
"""
from __future__ import annotations

import json
import operator
import os
import tempfile
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _ivdyn
from ._frames import frame_log, is_frame
from ._guard import real_array
from ._results import IdentifyResult, PayloadResult, read_prediction

PathLike = Union[str, "os.PathLike[str]"]
Progress = Union[None, bool, Callable[[int, int], Any]]


class tqdm_progress:
    """A progress callback drawing one tqdm bar per pipeline step (``progress=True``).
    Without tqdm installed it does nothing. Use as a context manager or call
    :meth:`close`."""

    def __init__(self) -> None:
        try:
            from tqdm.auto import tqdm  # type: ignore[import-untyped]
        except ImportError:  # tqdm is optional
            tqdm = None
        self._tqdm = tqdm
        self._bar: Any = None
        self._stage: Optional[str] = None

    def __call__(self, stage: str, done: int, total: int) -> None:
        if self._tqdm is None:
            return
        if stage != self._stage or self._bar is None:
            self.close()
            self._stage = stage
            self._bar = self._tqdm(total=total or None, desc=stage, unit="sample", leave=False)
        self._bar.update(done - self._bar.n)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> "tqdm_progress":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def _callback(progress: Progress):
    """The native callback ``(stage, done, total)`` for ``progress``, and a closer."""
    if progress is None or progress is False:
        return None, lambda: None
    if progress is True:
        bar = tqdm_progress()
        return bar, bar.close
    if not callable(progress):
        raise ValueError(f"progress must be None, True or a callable(done, total), got {type(progress).__name__}")
    user = progress
    return (lambda stage, done, total: user(done, total)), lambda: None


def _robot(robot, base: Optional[str], tip: Optional[str], fuse_beyond_tip: bool = False):
    """``robot`` as a native robot: an :class:`ivdyn.Robot`, or a URDF path (with the
    chain options of :meth:`ivdyn.Robot.from_urdf`)."""
    native = getattr(robot, "_r", None)
    if isinstance(native, _ivdyn.Robot):
        if base is not None or tip is not None or fuse_beyond_tip:
            raise ValueError("base/tip/fuse_beyond_tip are for a URDF path; the Robot already has its chain")
        return native
    if isinstance(robot, _ivdyn.Robot):
        return robot
    if isinstance(robot, (str, os.PathLike)):
        return _ivdyn.Robot.from_urdf(os.fspath(robot), base, tip, bool(fuse_beyond_tip))
    raise TypeError(f"robot must be an ivdyn.Robot or a URDF path, got {type(robot).__name__}")


def _params(params) -> Optional[str]:
    """A parameter file (path, or its dict as ``identify(...)["params"]``) as JSON text."""
    if params is None:
        return None
    if isinstance(params, dict):
        return json.dumps(params)
    if isinstance(params, (str, os.PathLike)):
        with open(params) as f:
            return f.read()
    raise TypeError(f"params must be a parameter-file path or dict, got {type(params).__name__}")


def _path(p: Optional[PathLike]) -> Optional[str]:
    return None if p is None else os.fspath(p)


def _log(log, native, what: str):
    """A log path, a dict of arrays (``t``, ``q``, optional ``qd``, ``tau``, ``u``,
    ``current``, ``joint_names``) converted to float64, or a pandas DataFrame in the CSV
    layout (``t``, ``<joint>.q``, ``.qd``, ``.tau``, ``.u``, ``.i``; ``_frames.py``) for the
    joints of ``native``."""
    if isinstance(log, (str, os.PathLike)):
        return os.fspath(log)
    if is_frame(log):
        log = frame_log(log, native.joint_names, what)
    if not isinstance(log, dict):
        raise TypeError(f"{what} must be a path, a dict of arrays or a pandas DataFrame, got {type(log).__name__}")
    n = native.dof
    out: Dict[str, Any] = {}
    for key, shape in (("t", 1), ("q", 2), ("qd", 2), ("tau", 2), ("u", 2), ("current", 2)):
        x = log.get(key)
        if x is None:
            continue
        a = real_array(x, f"{what}['{key}']")
        if a.ndim != shape or (shape == 2 and a.shape[1] != n):
            want = "(T,)" if shape == 1 else f"(T, {n})"
            raise ValueError(f"{what}['{key}'] must have shape {want}, got {a.shape}")
        out[key] = a
    if log.get("joint_names") is not None:
        out["joint_names"] = [str(j) for j in log["joint_names"]]
    return out


def _window(w) -> Optional[Tuple[float, float]]:
    """A ``(start, end)`` window in seconds, or None."""
    if w is None:
        return None
    try:
        a, b = w
        return float(a), float(b)
    except (TypeError, ValueError):
        raise ValueError(f"window must be (start, end) in seconds, got {w!r}") from None


def _spans(spans) -> Optional[List[Tuple[float, float]]]:
    """A list of ``(start, end)`` spans in seconds, or None."""
    if spans is None:
        return None
    out = []
    for w in spans:
        try:
            a, b = w
            out.append((float(a), float(b)))
        except (TypeError, ValueError):
            raise ValueError(f"exclude must be a list of (start, end) in seconds, got {spans!r}") from None
    return out


def _per_joint(x, what: str):
    """A per-joint value for the native module: a number (every joint), a list (one per
    joint), a dict ``{joint: number}``, or the command line's text."""
    if x is None or isinstance(x, str):
        return x
    if isinstance(x, dict):
        return {str(k): float(v) for k, v in x.items()}
    a = real_array(x, what)
    return float(a) if a.ndim == 0 else [float(v) for v in a.ravel()]


def _effort(current_topic, effort, torque_constant, gear_ratio, motor_constant) -> Dict[str, Any]:
    """The effort keywords of the native identify / payload / diagnose."""
    return dict(current_topic=None if current_topic is None else str(current_topic), effort=str(effort),
                torque_constant=_per_joint(torque_constant, "torque_constant"),
                gear_ratio=_per_joint(gear_ratio, "gear_ratio"),
                motor_constant=_per_joint(motor_constant, "motor_constant"))


def identify(robot, log, method: str = "wls", *, base: Optional[str] = None, tip: Optional[str] = None,
             fuse_beyond_tip: bool = False,
             params=None, validate=None, holdout: float = 0.25, topic: str = "/joint_states",
             command_topic: Optional[str] = None, log_time: bool = False, cutoff: Optional[float] = None,
             decimate: int = 0, friction: Sequence[str] = ("coulomb", "viscous"), armature: bool = True,
             offset: bool = True, consistent: bool = False, in_memory: bool = False,
             out_json: Optional[PathLike] = None, out_params: Optional[PathLike] = None,
             write_urdf: Optional[PathLike] = None, out_mcap: Optional[PathLike] = None,
             velocity: str = "auto", window: Optional[Tuple[float, float]] = None,
             exclude: Optional[Sequence[Tuple[float, float]]] = None, stream: bool = False,
             current_topic: Optional[str] = None, effort: str = "auto", torque_constant=None,
             gear_ratio=None, motor_constant=None, coulomb: str = "auto", prediction: bool = False,
             write_mjcf: Optional[PathLike] = None, report: Optional[PathLike] = None,
             progress: Progress = None) -> IdentifyResult:
    """``ivdyn identify`` from Python: base parameters of ``robot`` from a log with measured
    torques; returns the ``--json`` report as a dict (``docs/cli.md``: ``method``,
    ``base`` [{name, value, std, rel_std_pct, nominal}], ``fit``, ``validation``, ``dwh``,
    ``params`` (the identified full parameter file), ``notes``, ...). ``NaN`` values are
    ``None``, as in the JSON file.

    ``robot``: an :class:`ivdyn.Robot` or a URDF path (with ``base``/``tip`` links and
    ``fuse_beyond_tip``, as :meth:`ivdyn.Robot.from_urdf`); ``params``: a parameter file
    (path or dict, e.g. a previous ``["params"]``) replacing the nominal values; ``log``
    may be a list of logs of the same arm, identified together (each conditioned and
    filtered on its own, the held-out tail the last one's); ``log`` /
    ``validate``: a ``.mcap`` / ``.db3`` / ``.csv`` path or a ROS 2 bag directory (read as the
    command line reads ``--log``: ``topic``, ``command_topic``, ``log_time``) or a dict of
    arrays ``{"t": (T,) s, "q": (T, N) rad, "tau": (T, N) N m, "qd", "u" optional}`` (e.g.
    from :func:`read_joint_states` or :func:`simulate`), or a pandas DataFrame in the CSV
    layout (columns ``t``, ``<joint>.q``, optional ``.qd``, ``.tau``, ``.u``, ``.i``; every
    function taking a log takes one); ``method``: ``"ols"``, ``"wls"``,
    ``"iv"``, ``"idim-iv"``; ``holdout``: tail fraction kept for validation when no
    ``validate`` log; ``cutoff`` (Hz) and ``decimate`` as ``--cutoff``, ``--decimate``.

    The command line's other options: ``friction`` (``("none",)`` or some of
    ``"coulomb"``, ``"viscous"``), ``armature`` / ``offset`` (``False``: keep the nominal
    rotor inertia / torque offset), ``consistent`` (also fit physically consistent
    parameters), ``in_memory`` (read an MCAP log whole) / ``stream`` (stream even a small
    MCAP log; by default only logs of more than 1 M values are streamed), ``velocity``
    (``"auto"``: the log's velocity on each joint where it agrees with the differentiated
    positions; ``"log"``; ``"positions"``), ``window`` (``(start, end)`` seconds from the
    log's first sample; ``float("inf")`` for the end), ``exclude`` (a list of such spans
    left out; the log is cut there like at a gap), ``coulomb`` (``"auto"``: each joint's
    Coulomb friction shape chosen by held-out validation, reported in ``["coulomb"]``;
    ``"sign"``: the paper's ``sign(qd)``; ``"model"``: the shapes ``params`` brought); and the
    files: ``out_json`` (the report), ``out_params`` (the parameter file), ``write_urdf``
    (a copy of the robot's URDF with the identified parameters and its side file; the robot
    must come from a URDF), ``out_mcap`` (measured, predicted and residual torques),
    ``write_mjcf`` (a MuJoCo model of the chain with the identified inertials, ``armature``,
    ``damping`` = fv and ``frictionloss`` = fc, and its side file; refused with
    ``RuntimeError`` and nothing written when the parameters are not physically consistent:
    use ``consistent=True``; ``docs/mjcf.md``).
    ``report`` (an HTML page: fit quality per joint, base parameters, physical consistency,
    torque and residual plots; as ``--report``).
    ``prediction=True`` also reads those torques back (from ``out_mcap``, or a temporary
    file) into the result's ``prediction`` attribute (:func:`ivdyn.read_prediction`), which
    :mod:`ivdyn.plot` draws.

    The result is an :class:`IdentifyResult`: a dict equal to the JSON report, with a short
    ``repr`` and an HTML table in notebooks.

    Effort as motor current (``docs/logs.md``): ``effort`` is ``"auto"`` (the log's torque
    when it has one, else its motor current), ``"torque"`` or ``"current"``. Currents come
    from a log dict's ``"current"`` (A), CSV columns ``<joint>.i``, or the MCAP topic
    ``current_topic`` (its effort field; it may be ``topic`` itself), and become torques
    ``tau = k_t * i`` with ``torque_constant`` (N m/A at the joint), or ``gear_ratio`` times
    ``motor_constant``: each a number (every joint), one number per joint (base to tip), or
    a dict ``{joint: number}`` naming every joint.
    """
    native = _robot(robot, base, tip, fuse_beyond_tip)
    cb, close = _callback(progress)
    tmp = tempfile.TemporaryDirectory(prefix="ivdyn_prediction_") if prediction and out_mcap is None else None
    if tmp is not None:
        out_mcap = os.path.join(tmp.name, "prediction.mcap")
    try:
        logs = [_log(x, native, f"log[{i}]") for i, x in enumerate(log)] if isinstance(log, list) else None
        out = _ivdyn.identify(native, logs if logs is not None else _log(log, native, "log"), str(method),
                              None if validate is None else _log(validate, native, "validate"),
                              float(holdout), str(topic), command_topic, bool(log_time),
                              None if cutoff is None else float(cutoff), int(decimate), _params(params), cb,
                              friction=[str(f) for f in friction], armature=bool(armature), offset=bool(offset),
                              consistent=bool(consistent), in_memory=bool(in_memory), json_out=_path(out_json),
                              out_params=_path(out_params), write_urdf=_path(write_urdf), out_mcap=_path(out_mcap),
                              velocity=str(velocity), window=_window(window), exclude=_spans(exclude), stream=bool(stream),
                              coulomb=str(coulomb), write_mjcf=_path(write_mjcf), report=_path(report),
                              **_effort(current_topic, effort, torque_constant, gear_ratio, motor_constant))
        res = IdentifyResult(json.loads(out))
        if prediction and out_mcap is not None:  # always set with prediction (above)
            res.prediction = read_prediction(out_mcap, native.joint_names)
    finally:
        close()
        if tmp is not None:
            tmp.cleanup()
    return res


def payload(robot, log, before=None, *, base: Optional[str] = None, tip: Optional[str] = None,
            fuse_beyond_tip: bool = False,
            params=None, topic: str = "/joint_states",
            log_time: bool = False, cutoff: Optional[float] = None, decimate: int = 0,
            out_json: Optional[PathLike] = None, write_urdf: Optional[PathLike] = None,
            payload_as: str = "link", velocity: str = "auto", window: Optional[Tuple[float, float]] = None,
            exclude: Optional[Sequence[Tuple[float, float]]] = None,
            current_topic: Optional[str] = None, effort: str = "auto",
            torque_constant=None, gear_ratio=None, motor_constant=None,
            torque_constant_std=None, gains=None, write_mjcf: Optional[PathLike] = None,
            report: Optional[PathLike] = None, progress: Progress = None) -> PayloadResult:
    """``ivdyn payload`` from Python: the payload on the last link from a log after the
    grasp (and optionally ``before``, a log of the unloaded arm, identified first and used
    as the nominal model); returns the ``--json`` report as a dict: ``link``,
    ``identifiable``, ``mass`` (kg), ``com`` (m, link frame), ``inertia`` ([Ixx, Ixy, Ixz,
    Iyy, Iyz, Izz] kg m^2 about the COM: the JSON file's URDF attribute order,
    :func:`ivdyn.inertia_from_urdf` gives ivdyn's), their ``*_std``, ``params``,
    ``not_identifiable`` [{parameter, combined_in}], ``rms_before``/``rms_after`` (N m),
    ``physical`` (the least-squares payload, what it violated, the Mahalanobis distance to
    the nearest rigid body and its p-value), ``before_check`` (with ``before``: whether it
    fits this log), ``notes``. The numbers are those of the physically possible payload
    nearest to the least-squares one. When the payload is not identifiable from the log,
    ``identifiable`` is False and the numbers are None (the command line exits with 2).
    Arguments as in :func:`identify` (the effort options too); ``out_json``: the report
    file; ``report``: an HTML page (the estimate with std and 95 % intervals, physical
    validity, fit quality per joint, residual plots; as ``--report``); ``write_urdf``: a copy of the URDF with the payload, as a fixed child link of the tip (``payload_as="link"``)
    or merged into it (``"merge"``), written only when the payload is identifiable (and
    never with an inertia that is not a rigid body's: ``RuntimeError``, nothing written);
    ``write_mjcf``: a MuJoCo model of the arm as loaded with the payload as a body welded to
    the last link (same conditions; ``docs/mjcf.md``).

    When the effort is a current and the torque constants are themselves estimates, their
    uncertainty goes into the payload's std (``uncertainty_sources`` lists what the std
    cover): ``gains``, a :func:`drive_gains` report (dict) or its JSON file, whose
    determined gains become the torque constants with their covariance; the joints it
    leaves open take ``torque_constant`` with ``torque_constant_std`` (N m/A per joint,
    the forms of ``torque_constant``), which alone also work (independent errors).
    """
    native = _robot(robot, base, tip, fuse_beyond_tip)
    cb, close = _callback(progress)
    try:
        out = _ivdyn.payload(native, _log(log, native, "log"),
                             None if before is None else _log(before, native, "before"), str(topic),
                             bool(log_time), None if cutoff is None else float(cutoff),
                             int(decimate), _params(params), cb, json_out=_path(out_json),
                             write_urdf=_path(write_urdf), payload_as=str(payload_as), velocity=str(velocity),
                             window=_window(window), exclude=_spans(exclude),
                             **_effort(current_topic, effort, torque_constant, gear_ratio, motor_constant),
                             torque_constant_std=_per_joint(torque_constant_std, "torque_constant_std"),
                             gains=_gains_text(gains), write_mjcf=_path(write_mjcf), report=_path(report))
    finally:
        close()
    return PayloadResult(json.loads(out))


def _gains_text(gains) -> Optional[str]:
    """A drive_gains report as JSON text: a dict, or the path of its JSON file."""
    if gains is None or isinstance(gains, dict):
        return None if gains is None else json.dumps(gains)
    with open(os.fspath(gains)) as f:
        return f.read()


def drive_gains(robot, unloaded, loaded, payload_mass: float, *, payload_com: Optional[Sequence[float]] = None,
                payload_inertia: Optional[Sequence[float]] = None, base: Optional[str] = None,
                tip: Optional[str] = None, fuse_beyond_tip: bool = False, params=None,
                topic: str = "/joint_states", log_time: bool = False, cutoff: Optional[float] = None,
                decimate: int = 0, velocity: str = "auto", window: Optional[Tuple[float, float]] = None,
                current_topic: Optional[str] = None, effort: str = "auto", max_rel_std: float = 0.1,
                out_json: Optional[PathLike] = None, progress: Progress = None) -> Dict[str, Any]:
    """``ivdyn gains`` from Python: the drive gains (torque constants at the joint, N m per
    current unit, gear ratio included) from a log of the arm without the payload
    (``unloaded``) and one with a payload of known mass ``payload_mass`` (kg) on the last
    link (``loaded``), both with the drive currents. Returns the ``--json`` report as a dict
    (``docs/cli.md``): ``gains`` [{joint, identifiable, value, std, rel_std_pct, reason}]
    (``value`` and ``std`` are None for a gain the pair does not determine, with the
    reason), ``payload`` (the ten parameters, the COM), ``base`` (base parameters in
    absolute units), ``unloaded`` / ``loaded`` (residual RMS per joint, current units),
    ``notes``.

    ``unloaded``, ``loaded``: a ``.mcap`` / ``.csv`` path or a dict of arrays ``{"t": (T,)
    s, "q": (T, N) rad, "current": (T, N) A, "qd": optional}``. ``effort``: ``"auto"`` (the
    motor current when the log has one, else the effort field ``"tau"``), ``"current"``,
    ``"torque"`` (the effort field holds the current); ``current_topic``: the MCAP topic of
    the currents. ``payload_com`` (x, y, z) m and ``payload_inertia`` (Ixx, Ixy, Iyy, Ixz,
    Iyz, Izz: ivdyn's order, as in ``robot.params``) kg m^2 about the COM, when known (else estimated). ``max_rel_std``: a gain
    whose relative std is larger is reported as not identifiable. The other arguments as
    in :func:`identify`.
    """
    native = _robot(robot, base, tip, fuse_beyond_tip)

    def seq(x, name):
        return None if x is None else [float(v) for v in real_array(x, name).ravel()]

    cb, close = _callback(progress)
    try:
        text = _ivdyn.gains(native, _log(unloaded, native, "unloaded"), _log(loaded, native, "loaded"),
                            float(payload_mass), seq(payload_com, "payload_com"), seq(payload_inertia, "payload_inertia"), str(topic), bool(log_time),
                            None if cutoff is None else float(cutoff), int(decimate), _params(params), cb,
                            json_out=_path(out_json), velocity=str(velocity), window=_window(window),
                            current_topic=None if current_topic is None else str(current_topic),
                            effort=str(effort), max_rel_std=float(max_rel_std))
    finally:
        close()
    return json.loads(text)


def simulate(robot, out: Optional[PathLike] = None, *, base: Optional[str] = None, tip: Optional[str] = None,
             fuse_beyond_tip: bool = False,
             params=None, traj=None, duration: float = 20.0, rate: float = 500.0, seed: int = 1,
             amplitude: float = 0.8, payload_mass: Optional[float] = None,
             payload_com: Optional[Sequence[float]] = None, payload_inertia: Optional[Sequence[float]] = None,
             fc: Optional[Sequence[float]] = None, fv: Optional[Sequence[float]] = None, noise: float = 0.0,
             noise_q: float = 0.0, encoder_bits: Optional[int] = None, tau_resolution: Optional[float] = None,
             velocity: bool = True, command: bool = False, out_json: Optional[PathLike] = None) -> Dict[str, Any]:
    """``ivdyn simulate`` from Python: a synthetic log, the true model's inverse dynamics
    along a trajectory (``robot`` + payload on the last link + friction ``fc``, ``fv``),
    then noise (``noise`` N m on the torque, ``noise_q`` rad on the position) and
    quantisation (``encoder_bits``, ``tau_resolution`` N m). Trajectory: ``traj`` =
    ``{"t": (T,) s uniformly spaced, "q": (T, N) rad}`` or a CSV path (columns ``t``,
    ``<joint>.q``), else the built-in random Fourier excitation (``duration`` s at ``rate``
    Hz, ``seed``, peak ``amplitude`` rad). Payload: ``payload_mass`` kg, ``payload_com``
    (x, y, z) m and ``payload_inertia`` (Ixx, Ixy, Iyy, Ixz, Iyz, Izz: ivdyn's order,
    as in ``robot.params``) kg m^2 about the COM
    in the last link's frame. ``command``: also record the noise-free torque as the
    command ``u``; ``velocity=False``: no velocities in the log.

    Writes the log to ``out`` (``.mcap`` or ``.csv``) and the summary to ``out_json`` when
    given. Returns the command's
    ``--json`` summary ``{"out", "samples", "joints", "options", "true_params"}`` plus
    ``"log": {"t": (T,), "q", "qd", "tau", "u": (T, N) or None, "joint_names"}``, which
    :func:`identify` and :func:`payload` accept as a log.
    """
    native = _robot(robot, base, tip, fuse_beyond_tip)
    n = native.dof
    tt = tq = None
    if traj is not None:
        if isinstance(traj, (str, os.PathLike)):
            traj = _ivdyn.read_joint_states(os.fspath(traj), native.joint_names)
        elif is_frame(traj):
            traj = frame_log(traj, native.joint_names, "traj")
        if not isinstance(traj, dict) or "t" not in traj or "q" not in traj:
            raise ValueError("traj must be a dict {'t': (T,), 'q': (T, N)} or a CSV path")
        lg = _log({"t": traj["t"], "q": traj["q"]}, native, "traj")
        tt, tq = lg["t"], lg["q"]

    def seq(x, name):
        return None if x is None else [float(v) for v in real_array(x, name).ravel()]

    summary, log = _ivdyn.simulate(native, None if out is None else os.fspath(out), tt, tq, float(duration),
                                   float(rate), int(seed), float(amplitude),
                                   None if payload_mass is None else float(payload_mass),
                                   seq(payload_com, "payload_com"), seq(payload_inertia, "payload_inertia"),
                                   seq(fc, "fc"), seq(fv, "fv"), float(noise), float(noise_q),
                                   None if encoder_bits is None else int(encoder_bits),
                                   None if tau_resolution is None else float(tau_resolution),
                                   bool(velocity), bool(command), _params(params), json_out=_path(out_json))
    res = json.loads(summary)
    res["log"] = log
    return res


def diagnose(robot, log, out: Optional[Union[str, "os.PathLike[str]"]] = None, *, base: Optional[str] = None,
             tip: Optional[str] = None, fuse_beyond_tip: bool = False, params=None, topic: str = "/joint_states",
             log_time: bool = False, cutoff: Optional[float] = None, alpha: float = 1e-3, min_effect: float = 0.5,
             ignore_log_velocity: bool = False, report: bool = True, out_json: Optional[PathLike] = None,
             velocity: str = "auto", window: Optional[Tuple[float, float]] = None,
             exclude: Optional[Sequence[Tuple[float, float]]] = None, current_topic: Optional[str] = None, effort: str = "auto", torque_constant=None,
             gear_ratio=None, motor_constant=None, drives: Optional[bool] = None, verdict: bool = False,
             threads: Optional[int] = None, max_dictionary_gib: Optional[float] = None,
             progress: Progress = None) -> Dict[str, Any]:
    """``ivdyn diagnose`` from Python: what the nominal ``robot`` misses in a log with
    measured torques. Returns the content of ``diagnosis.json`` (``docs/diagnose.md``):
    ``effects`` [{name, joints, parameters, parameters_std, rms_before, rms_after}] in the
    order found (empty when nothing is missing; ``parameters_std``: the standard error of
    each parameter, noise, folds and the re-fit's ridge; still a lower bound of the error on
    CAD-error logs, ``docs/diagnose.md`` "Uncertainty"), ``baseline_rms`` and ``final_rms`` (N m per joint), ``joints``,
    ``nominal_refit`` {base_params, rms_before, rms_after, why} when the nominal rigid-body
    model was re-fitted, ``next_command`` (the ``ivdyn identify`` command to run next)
    when something was found, and ``detectable`` (per joint, the smallest offset, direction
    dependence of friction, spring, gain error and armature the log can tell from the links'
    inertials; ``docs/diagnose.md`` "What the log can show"). With ``out`` (a directory) it also writes ``diagnosis.json``,
    ``report.html`` (unless ``report=False``) and ``residuals.mcap`` there.

    ``robot``: an :class:`ivdyn.Robot` or a URDF path (``base``/``tip`` links,
    ``fuse_beyond_tip``); ``params``: a parameter file replacing the nominal values;
    ``log``: a ``.mcap`` / ``.csv`` path or a dict of arrays ``{"t": (T,) s, "q": (T, N)
    rad, "tau": (T, N) N m, "qd": optional}`` (or motor currents: the effort options of
    :func:`identify`); ``cutoff`` (Hz): differentiation low-pass (default: chosen from the
    data); ``alpha``: F-test level; ``min_effect``: smallest effect named, in noise
    standard deviations; ``out_json``: a second copy of diagnosis.json; ``velocity`` and
    ``window`` as in :func:`identify` (``ignore_log_velocity=True`` is
    ``velocity="positions"``); ``drives``: search the effects of real drives
    (smooth and load-dependent friction, torque gain, torque ripple, time delay): ``True``
    (``--drives``), ``False`` (``--no-drives``), or ``None`` (default): on logs of at least
    4 s with white torque noise, ``docs/diagnose.md``; direction-dependent friction, a refinement of Coulomb
    friction found on a joint, is searched either way; ``verdict``: also return the
    report's headline (``verdict``: one sentence) and the lines below it (``details``: each
    effect, what is left above the noise and why nothing was named on it); ``threads``: most
    threads to use (``1``: the calling thread alone, e.g. in a fleet worker that runs
    diagnoses side by side; default: the machine's cores on logs of 20 000 samples or more,
    else one). The result is the same with any count. ``max_dictionary_gib``: most memory
    (GiB, default 4) for the candidate columns the diagnosis fits (about 10 MB per second
    of a 1 kHz, 7-joint log): a longer log is diagnosed on blocks spread over all of it,
    and a detail says so.
    """
    native = _robot(robot, base, tip, fuse_beyond_tip)
    cb, close = _callback(progress)
    try:
        text = _ivdyn.diagnose(native, _log(log, native, "log"), _path(out), str(topic), bool(log_time),
                               None if cutoff is None else float(cutoff), float(alpha), float(min_effect),
                               bool(ignore_log_velocity), bool(report), _params(params),
                               json_out=_path(out_json), progress=cb, velocity=str(velocity),
                               window=_window(window), exclude=_spans(exclude),
                               drives=None if drives is None else bool(drives),
                               verdict=bool(verdict),
                               threads=None if threads is None else operator.index(threads),
                               max_dictionary_gib=None if max_dictionary_gib is None else float(max_dictionary_gib),
                               **_effort(current_topic, effort, torque_constant, gear_ratio, motor_constant))
    finally:
        close()
    return json.loads(text)


def excite(robot, out: Optional[PathLike] = None, *, base: Optional[str] = None, tip: Optional[str] = None,
           fuse_beyond_tip: bool = False,
           params=None, out_mcap: Optional[PathLike] = None, out_json: Optional[PathLike] = None,
           duration: float = 20.0, harmonics: int = 5, f0: float = 0.1, rate: float = 100.0,
           criterion: str = "cond", acc_limit: Union[float, Sequence[float]] = 5.0,
           vel_limit: Optional[Union[float, Sequence[float]]] = None, margin: float = 0.01, starts: int = 6,
           iterations: int = 150, random: int = 20, seed: int = 1, progress: Progress = None) -> Dict[str, Any]:
    """``ivdyn excite`` from Python: an excitation trajectory for ``robot`` (a finite
    Fourier series of ``harmonics`` harmonics of ``f0`` Hz, ``duration`` s at ``rate`` Hz)
    whose base regressor is as well conditioned as the limits allow (``criterion``:
    ``"cond"`` or ``"logdet"``; ``acc_limit`` rad/s^2 and ``vel_limit`` rad/s, one value or
    one per joint; ``margin``: fraction every limit is shrunk). Writes the trajectory to
    ``out`` (CSV: ``t``, ``<joint>.q``, ``.qd``, ``.qdd``) and ``out_mcap``, the report to
    ``out_json`` when given. Returns the ``--json`` report as a dict plus ``"trajectory"``:
    ``{"t": (T,), "q", "qd", "qdd": (T, N), "joint_names"}``.
    """
    native = _robot(robot, base, tip, fuse_beyond_tip)

    def seq(x, name):
        return None if x is None else [float(v) for v in np.atleast_1d(real_array(x, name))]

    cb, close = _callback(progress)
    try:
        text, traj = _ivdyn.excite(native, _path(out), _path(out_mcap), _path(out_json), float(duration),
                                   int(harmonics), float(f0), float(rate), str(criterion), seq(acc_limit, "acc_limit"),
                                   seq(vel_limit, "vel_limit"), float(margin), int(starts), int(iterations), int(random),
                                   int(seed), _params(params), cb)
    finally:
        close()
    res = json.loads(text)
    res["trajectory"] = traj
    return res
