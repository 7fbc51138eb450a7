"""Plotting helpers (matplotlib, imported when called)."""
from __future__ import annotations

from typing import Optional, Sequence, Union

import numpy as np

__all__ = ["paper_traces"]


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
