"""The Ray engine of :func:`ivdyn.fleet.run`: one task per log, a tree of merge tasks per
(robot, period), one fit task per group. Imported only when Ray is used."""
from __future__ import annotations

import os
from typing import Any, Dict, List, Optional, Sequence, Tuple

import ray

from . import LogEntry, Options, Progress, _groups, _safe_fit, _safe_stats, merge

#: Retries of a task whose worker died (a lost node, a killed process): the statistics
#: are a pure function of the log, so a retry gives the same bytes.
MAX_RETRIES = 3

def _stats_parts(entry: LogEntry, options: Options) -> Tuple[Tuple[str, Optional[str]], bytes]:
    """:func:`_safe_stats` as two objects: the status (small, fetched by the driver) and the
    statistics (left in the object store for the merge tasks; empty when failed)."""
    status, value = _safe_stats(entry, options)
    return (status, None if status == "ok" else value), (value if status == "ok" else b"")


def _merge_parts(*parts: bytes) -> bytes:
    return merge(parts)


#: Environment of the workers of a local runtime. glibc gives each thread that allocates a
#: malloc arena of its own and keeps freed memory in it; the per-log pass starts short-lived
#: threads block after block, so a worker that runs log after log grew to ~3x one log's
#: peak (336 MB against 105 MB idle, measured); two arenas keep it at one log's.
WORKER_ENV = {"MALLOC_ARENA_MAX": "2"}

_stats_task: Any = ray.remote(num_returns=2, max_retries=MAX_RETRIES)(_stats_parts)
_merge_task: Any = ray.remote(max_retries=MAX_RETRIES)(_merge_parts)
_fit_task: Any = ray.remote(max_retries=MAX_RETRIES)(_safe_fit)


def start(address: Optional[str] = None, num_cpus: Optional[int] = None) -> None:
    """Connects to the cluster at ``address`` (or ``RAY_ADDRESS``), else starts a local
    runtime with ``num_cpus`` CPUs (default: the machine's) and :data:`WORKER_ENV`;
    nothing if Ray is running."""
    if ray.is_initialized():
        return
    address = address or os.environ.get("RAY_ADDRESS")
    if address:
        ray.init(address=address)
    else:
        ray.init(num_cpus=num_cpus or os.cpu_count(), include_dashboard=False,
                 runtime_env={"env_vars": WORKER_ENV})


def map_ray(fn: Any, items: Sequence[Any], address: Optional[str], num_cpus: Optional[int], *args: Any
            ) -> List[Any]:
    """``[fn(x, *args) for x in items]``, one Ray task per item (retried as the statistics
    are): the diagnoses of :func:`ivdyn.fleet.diagnose`."""
    start(address, num_cpus)
    task = ray.remote(max_retries=MAX_RETRIES)(fn)
    return ray.get([task.remote(x, *args) for x in items])


def run_ray(entries: Sequence[LogEntry], options: Options, address: Optional[str], num_cpus: Optional[int],
            progress: Progress, fan_in: int) -> Tuple[List[Tuple[str, Any]], Dict, Dict]:
    start(address, num_cpus)
    pairs: List[Any] = [_stats_task.remote(e, options) for e in entries]
    status_refs = [p[0] for p in pairs]
    pending = list(status_refs)
    while pending:  # the map, with progress as logs finish
        _, pending = ray.wait(pending, num_returns=1)
        if progress is not None:
            progress(len(status_refs) - len(pending), len(status_refs))
    statuses = ray.get(status_refs)
    done = [(s, msg) for s, msg in statuses]
    stats_refs: Dict[Tuple[str, str], Any] = {}
    fit_refs: Dict[Tuple[str, str], Any] = {}
    for key, idx in _groups(entries, done).items():
        # the tree over object references: the statistics never pass through the driver
        level: List[Any] = [pairs[i][1] for i in idx]
        while len(level) > 1:
            level = [_merge_task.remote(*level[k:k + fan_in]) if len(level[k:k + fan_in]) > 1 else level[k]
                     for k in range(0, len(level), fan_in)]
        stats_refs[key] = level[0]
        fit_refs[key] = _fit_task.remote(entries[idx[0]], level[0], options)
    stats = {key: ray.get(ref) for key, ref in stats_refs.items()}
    fits = {key: ray.get(ref) for key, ref in fit_refs.items()}
    return done, stats, fits
