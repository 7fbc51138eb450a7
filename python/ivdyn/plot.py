"""Plotting helpers (matplotlib, imported when called: ``pip install ivdyn[plot]``).

From an identification (``res = ivdyn.identify(robot, log, prediction=True)``):
:func:`torques` (measured against predicted torque, one panel per joint),
:func:`residuals` (residual against time or against joint velocity) and
:func:`parameters` (the base parameters with their standard deviations, as a table).
``res`` may also be the dict of :func:`ivdyn.read_prediction` (an ``--out-mcap`` file of
the command line). Every function draws on the axes given (else a new figure) and returns
the figure; the plotted data are the result's arrays, unchanged.
"""
from __future__ import annotations

from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np

__all__ = ["paper_traces", "torques", "residuals", "parameters"]


def _pyplot():
    try:
        import matplotlib.pyplot as plt
    except ImportError:
        raise ImportError("ivdyn.plot needs matplotlib: pip install ivdyn[plot] (or matplotlib)") from None
    return plt


def _prediction(res: Any) -> Dict[str, Any]:
    """The prediction arrays of an identify result, or the dict of read_prediction."""
    pred = getattr(res, "prediction", None)
    if pred is None and isinstance(res, dict) and "predicted" in res:
        pred = res
    if pred is None:
        raise ValueError("no predicted torques: call ivdyn.identify(..., prediction=True), or pass "
                         "ivdyn.read_prediction(out_mcap, robot)")
    return pred


def _joints(pred: Dict[str, Any], joints: Optional[Sequence[Union[int, str]]]) -> List[int]:
    names = list(pred["joint_names"])
    if joints is None:
        return list(range(len(names)))
    out = []
    for j in joints:
        if isinstance(j, (int, np.integer)) and 0 <= int(j) < len(names):
            out.append(int(j))
        elif j in names:
            out.append(names.index(j))
        else:
            raise ValueError(f"no joint {j!r} (joints: {names})")
    return out


def _grid(plt, k: int, axes, width: float = 6.0, height: float = 2.0):
    """``k`` axes: the caller's (a sequence of at least ``k``) or a new column of panels."""
    if axes is not None:
        axes = list(np.ravel(axes))
        if len(axes) < k:
            raise ValueError(f"axes: {k} panels needed, got {len(axes)}")
        return axes[0].figure, axes[:k]
    fig, ax = plt.subplots(k, 1, figsize=(width, height * k), sharex=True, squeeze=False)
    return fig, list(ax[:, 0])


def torques(res: Any, joints: Optional[Sequence[Union[int, str]]] = None, axes=None):
    """Measured (``C0``) and predicted (``C1``) torque against time, one panel per joint
    (``joints``: names or indices, default all). Returns the figure."""
    plt = _pyplot()
    pred = _prediction(res)
    idx = _joints(pred, joints)
    fig, axes = _grid(plt, len(idx), axes)
    t = pred["t"]
    for ax, j in zip(axes, idx):
        ax.plot(t, pred["measured"][:, j], lw=0.8, color="C0", label="measured")
        ax.plot(t, pred["predicted"][:, j], lw=0.8, color="C1", label="predicted")
        ax.set_ylabel(f"{pred['joint_names'][j]}\nN m", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel("t (s)")
    return fig


def residuals(res: Any, against: str = "time", joints: Optional[Sequence[Union[int, str]]] = None, axes=None):
    """Residual (measured - predicted, N m) against time (``against="time"``, a line) or
    against the joint velocity the model was evaluated at (``"velocity"``, dots: friction
    the model lacks shows as a step at 0 or a slope). One panel per joint. Returns the figure."""
    if against not in ("time", "velocity"):
        raise ValueError(f"against must be 'time' or 'velocity', got {against!r}")
    plt = _pyplot()
    pred = _prediction(res)
    idx = _joints(pred, joints)
    fig, axes = _grid(plt, len(idx), axes)
    for ax, j in zip(axes, idx):
        r = pred["residual"][:, j]
        if against == "time":
            ax.plot(pred["t"], r, lw=0.6, color="C3")
        else:
            ax.plot(pred["qd"][:, j], r, ".", ms=1.5, color="C3")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel(f"{pred['joint_names'][j]}\nN m", fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("t (s)" if against == "time" else "qd (rad/s)")
    if against == "velocity":
        for ax in axes:
            ax.tick_params(labelbottom=True)
    return fig


def parameter_rows(res: Any, digits: int = 4) -> List[List[str]]:
    """The rows of :func:`parameters`: ``[name, value, std, rel std %]`` of each base
    parameter of an identify result (its ``["base"]``), as text."""
    base = res.get("base") if isinstance(res, dict) else None
    if base is None:
        raise ValueError("parameters needs an identify result (a dict with 'base')")

    def num(x, spec):
        return "-" if x is None else format(float(x), spec)
    return [[b["name"], num(b.get("value"), f".{digits}g"), num(b.get("std"), ".2g"),
             num(b.get("rel_std_pct"), ".3g")] for b in base]


def parameters(res: Any, ax=None, max_name: int = 60, digits: int = 4):
    """The base parameters of an identify result with their standard deviations, as a
    matplotlib table (names cut to ``max_name`` characters; :func:`parameter_rows` has
    the same cells as text). Returns the figure."""
    plt = _pyplot()
    rows = parameter_rows(res, digits)
    rows = [[r[0] if len(r[0]) <= max_name else r[0][: max_name - 3] + "..."] + r[1:] for r in rows]
    if ax is None:
        _, ax = plt.subplots(figsize=(9, 0.25 * (len(rows) + 2)))
    ax.axis("off")
    if rows:
        table = ax.table(cellText=rows, colLabels=["base parameter", "value", "std", "rel std %"],
                         loc="upper center", cellLoc="right", colLoc="right", colWidths=[0.58, 0.14, 0.14, 0.14])
        table.auto_set_font_size(False)
        table.set_fontsize(7)
        for (r, c), cell in table.get_celld().items():
            if c == 0:
                cell.set_text_props(ha="left")
    return ax.figure


def _param_index(names: Sequence[str], param: Union[int, str]) -> int:
    if isinstance(param, (int, np.integer)):
        return int(param)
    for i, n in enumerate(names):
        if n == param:
            return i
    for i, n in enumerate(names):  # a combination whose first term is `param`
        if n.split(" ")[0] == param:
            return i
    raise ValueError(f"no base parameter named {param!r} (names: {list(names)})")


def paper_traces(names: Sequence[str], truth, n, estimates, labels: Sequence[str],
                 estimator: int = 1, ax=None, param: Union[int, str, None] = None):
    """Estimates against the number of samples, as in the paper's Figs 2-3.

    ``names``: ``B`` base names; ``truth``: ``(B,)``; ``n``: ``(C,)`` sample counts;
    ``estimates``: ``(E, C, B)`` (from :func:`ivdyn.paper.recursive_traces` or
    ``batch_estimates``); ``labels``: ``E`` estimator labels; ``estimator``: which one to
    draw (LSM, index 0, is drawn in grey behind it). With ``param`` (index or name, a
    combination also matches by its first term, e.g. ``"link6.Izz"``) one panel is drawn
    on ``ax`` (a new figure if None) and ``ax`` is returned; without it, a grid of every
    link-6 / joint-6 combination is drawn and the figure is returned.
    """
    import matplotlib.pyplot as plt

    est = np.asarray(estimates, dtype=float)
    truth = np.asarray(truth, dtype=float)
    n = np.asarray(n)
    if est.ndim != 3 or est.shape[1] != n.shape[0] or est.shape[2] != len(names):
        raise ValueError(f"estimates must have shape (E, {n.shape[0]}, {len(names)}), got {est.shape}")
    if not 0 <= estimator < est.shape[0]:
        raise ValueError(f"estimator must be in 0..{est.shape[0] - 1}, got {estimator}")

    def panel(ax, b):
        if estimator != 0:
            ax.semilogx(n, est[0, :, b], lw=1.0, color="0.65", label=labels[0])
        ax.semilogx(n, est[estimator, :, b], lw=1.4, color="C0", label=labels[estimator])
        ax.axhline(truth[b], color="k", ls="--", lw=1, label="truth")
        span = abs(truth[b]) if abs(truth[b]) > 1e-9 else max(np.abs(est[estimator, -1, b] - truth[b]), 1e-3)
        ax.set_ylim(truth[b] - 1.5 * span, truth[b] + 1.5 * span)
        ax.set_title(names[b], fontsize=9)
        ax.set_xlabel("samples N (1 kHz)")
        ax.grid(alpha=0.3)

    if param is not None:
        b = _param_index(names, param)
        if ax is None:
            _, ax = plt.subplots(figsize=(5, 3.5))
        panel(ax, b)
        ax.legend(fontsize=7)
        return ax
    idx = [i for i, nm in enumerate(names) if "link6" in nm or "joint6" in nm]
    cols = 3
    rows = int(np.ceil(len(idx) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 2.9 * rows), squeeze=False)
    for a, b in zip(axes.flat, idx):
        panel(a, b)
    for a in list(axes.flat)[len(idx):]:
        a.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.tight_layout()
    return fig
