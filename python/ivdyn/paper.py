"""The paper's simulation study (Kawasaki and Nishimura; ``docs/paper-reproduction.md``)
from Python: the terminal-link identification of links 5-6 of the paper's arm with LSM
and three IVM variants, batch (Monte Carlo tables) or recursive (Figs 2 and 3).

Example (Fig. 3, the IVM trace of one combination)::

    import ivdyn, ivdyn.plot
    sim = ivdyn.paper.setup(0)
    n = ivdyn.paper.log_points(100, 100_000)
    est = ivdyn.paper.recursive_traces(0, 0, n)              # (4, len(n), B)
    ivdyn.plot.paper_traces(sim.base_names, sim.truth_base, n, est, ivdyn.paper.ESTIMATORS,
                            estimator=1, param="link6.Izz")
"""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from . import _ivdyn

__all__ = ["ESTIMATORS", "PaperSim", "setup", "batch_estimates", "recursive_traces", "log_points"]

#: Labels of the estimators, in the order of the first axis of the estimates:
#: LSM, IVM (eq-35 instrument), IVM (nominal-model instrument), IVM (planned acceleration).
ESTIMATORS = tuple(_ivdyn.paper_estimators())

PaperSim = _ivdyn.PaperSim


def setup(seed: int = 0, accel_noise: Optional[float] = None) -> "PaperSim":
    """The set-up for nominal-error seed ``seed``: ``base_names`` (``B`` identifiable
    combinations of the 24 unknowns), ``truth_base`` (``(B,)``), ``full_names``, ``dt``
    (s), ``accel_noise`` (rad/s^2 std of the measured accelerations, 10 in the paper;
    settable), ``row_weight``; methods ``batch_estimates`` and ``recursive_traces``."""
    sim = _ivdyn.PaperSim(int(seed))
    if accel_noise is not None:
        sim.accel_noise = float(accel_noise)
    return sim


def _counts(x: Sequence[int]) -> list:
    return [int(v) for v in np.asarray(x).ravel()]


def batch_estimates(seed: int, noise_seed: int, checkpoints: Sequence[int],
                    accel_noise: Optional[float] = None) -> np.ndarray:
    """Batch estimates of every estimator after ``checkpoints`` samples (strictly
    increasing, 1 kHz), shape ``(len(ESTIMATORS), len(checkpoints), B)``; ``seed``: nominal
    errors, ``noise_seed``: measurement noise. Runs in Rust with the GIL released."""
    return setup(seed, accel_noise).batch_estimates(int(noise_seed), _counts(checkpoints))


def recursive_traces(seed: int, noise_seed: int, record: Sequence[int], p0: float = 1e4,
                     accel_noise: Optional[float] = None) -> np.ndarray:
    """Recursive estimates (RLS / RIV from zero, covariance ``p0 I``) recorded after
    ``record`` samples (strictly increasing), shape ``(len(ESTIMATORS), len(record), B)``."""
    return setup(seed, accel_noise).recursive_traces(int(noise_seed), _counts(record), float(p0))


def log_points(start: int, stop: int, per_decade: int = 20) -> np.ndarray:
    """Strictly increasing sample counts from ``start`` to ``stop``, log-spaced."""
    if not (1 <= start <= stop):
        raise ValueError(f"need 1 <= start <= stop, got {start}, {stop}")
    k = max(2, int(round(np.log10(stop / start) * per_decade)) + 1)
    return np.unique(np.round(np.geomspace(start, stop, k)).astype(np.int64))
