"""ivdyn.fleet: identify many robots from many logs on Ray (or any map/reduce engine).

The work per log is engine-neutral: :func:`log_stats` turns one log into its sufficient
statistics (bytes: versioned, with the robot model's fingerprint; computed in Rust with
the GIL released, with ``identify``'s conditioning and hygiene), :func:`merge` combines
statistics (associative: any tree gives the same fit to rounding) and :func:`fit` fits
them with covariances. :func:`run` drives a manifest through an engine:

* ``engine="ray"``: one Ray task per log, a tree reduction per (robot, period), one fit
  task per group. With no ``address`` (and no ``RAY_ADDRESS``) a local Ray runtime with
  the machine's CPU count; a worker lost mid-run is retried by Ray (``max_retries``) and
  the statistics, being a pure function of the log, are the same.
* ``engine="local"``: the same steps in this process on a thread pool (the Rust work
  releases the GIL), no Ray needed.

Another engine is a few lines (``docs/fleet.md``), e.g. with ``concurrent.futures``::

    with ProcessPoolExecutor() as ex:
        parts = list(ex.map(fleet.log_stats, entries))
    stats = fleet.merge(parts)
    result = fleet.fit(entries[0].model, stats)

A log that cannot be used (corrupt, wrong joints) marks its manifest row failed, with
the error naming the file, and the run goes on.
"""
from __future__ import annotations

import csv
import dataclasses
import json
import os
import re
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

from .. import _ivdyn
from . import _s3

__all__ = [
    "LogEntry", "Options", "FleetResult", "read_manifest", "manifest_from_glob",
    "log_stats", "merge", "fit", "stats_info", "run", "drift", "changes", "diagnose", "write_report",
]

#: Progress callback: ``progress(done, total)`` after each log.
Progress = Optional[Callable[[int, int], None]]

#: Manifest columns (``log``, ``robot`` and ``model`` required).
COLUMNS = ("log", "robot", "model", "period", "time", "payload", "base", "tip")


@dataclasses.dataclass(frozen=True)
class LogEntry:
    """One manifest row: the log (path), the robot's id, its model (URDF path, with the
    chain's ``base``/``tip`` links), the period it belongs to (default: the date of
    ``time``, else ``"all"``) and an optional payload tag."""
    log: str
    robot: str
    model: str
    period: str = "all"
    time: Optional[str] = None
    payload: Optional[str] = None
    base: Optional[str] = None
    tip: Optional[str] = None


@dataclasses.dataclass(frozen=True)
class Options:
    """How statistics are built and fitted: must be the same for every log of a fleet
    (``method``: ``"ols"`` or ``"wls"``; the rest as :func:`ivdyn.identify`)."""
    method: str = "wls"
    cutoff: Optional[float] = None
    decimate: int = 0
    friction: Tuple[str, ...] = ("coulomb", "viscous")
    armature: bool = True
    offset: bool = True
    topic: str = "/joint_states"
    log_time: bool = False
    #: stream MCAP logs (memory bounded by the stream's buffers, whatever a log's length;
    #: the log's velocity taken where it is consistent, as in memory); False reads every
    #: log into memory (about 6 kB a sample; docs/fleet.md, "Memory")
    stream: bool = True

    def _fit_kwargs(self) -> Dict[str, Any]:
        return dict(cutoff=self.cutoff, decimate=self.decimate, friction=list(self.friction),
                    armature=self.armature, offset=self.offset, method=self.method)


def _entry(row: Dict[str, Any], where: str, root: str) -> LogEntry:
    """A manifest row as a :class:`LogEntry`: relative paths are taken from the manifest's
    directory ``root``; ``where`` names the row in errors."""
    unknown = sorted(set(row) - set(COLUMNS))
    if unknown:
        raise ValueError(f"{where}: unknown column(s) {unknown}; the columns are {list(COLUMNS)}")
    vals = {k: (str(v).strip() if v is not None and str(v).strip() != "" else None) for k, v in row.items()}
    for k in ("log", "robot", "model"):
        if not vals.get(k):
            raise ValueError(f"{where}: '{k}' is missing (every row needs log, robot and model)")

    def at(p: str) -> str:
        return p if "://" in p or os.path.isabs(p) else os.path.join(root, p)

    log, robot, model = (str(vals[k]) for k in ("log", "robot", "model"))
    time = vals.get("time")
    period = vals.get("period") or (time[:10] if time else "all")
    return LogEntry(log=at(log), robot=robot, model=at(model), period=period, time=time,
                    payload=vals.get("payload"), base=vals.get("base"), tip=vals.get("tip"))


def read_manifest(path: Union[str, "os.PathLike[str]"]) -> List[LogEntry]:
    """The rows of a manifest: CSV with a header naming the columns (:data:`COLUMNS`), or
    JSON (a list of objects, or ``{"logs": [...]}``). Relative paths are relative to the
    manifest's directory."""
    path = str(os.fspath(path))
    root = os.path.dirname(os.path.abspath(path))
    with open(path, newline="") as f:
        if path.lower().endswith(".json"):
            doc = json.load(f)
            rows = doc.get("logs") if isinstance(doc, dict) else doc
            if not isinstance(rows, list):
                raise ValueError(f"{path}: a JSON manifest is a list of rows or {{\"logs\": [rows]}}")
        else:
            rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{path}: the manifest has no rows")
    return [_entry(r, f"{path}: row {i + 1}", root) for i, r in enumerate(rows)]


def manifest_from_glob(pattern: str, rule: str, model: str, *, base: Optional[str] = None,
                       tip: Optional[str] = None) -> List[LogEntry]:
    """Rows from the files matching the glob ``pattern``, named by the regular expression
    ``rule`` with the groups ``robot`` and ``period`` (optional ``payload``), e.g.
    ``r"(?P<robot>arm-\\d+)/(?P<period>\\d{4}-\\d\\d-\\d\\d)\\.mcap$"``; every robot has the
    model ``model``. A file the rule does not match is an error naming it."""
    import glob

    rx = re.compile(rule)
    if "robot" not in rx.groupindex:
        raise ValueError(f"naming rule {rule!r} needs a group (?P<robot>...)")
    out = []
    for p in sorted(glob.glob(pattern, recursive=True)):
        m = rx.search(p)
        if not m:
            raise ValueError(f"{p}: does not match the naming rule {rule!r}")
        g = m.groupdict()
        out.append(LogEntry(log=p, robot=g["robot"], model=model, period=g.get("period") or "all",
                            payload=g.get("payload"), base=base, tip=tip))
    if not out:
        raise ValueError(f"no file matches {pattern!r}")
    return out


_ROBOTS: Dict[Tuple[str, Optional[str], Optional[str]], Any] = {}


def _robot(model: str, base: Optional[str], tip: Optional[str]):
    """The native robot of a URDF, loaded once per process."""
    key = (model, base, tip)
    if key not in _ROBOTS:
        _ROBOTS[key] = _ivdyn.Robot.from_urdf(model, base, tip, False)
    return _ROBOTS[key]


def log_stats(entry: LogEntry, options: Options = Options()) -> bytes:
    """The sufficient statistics of one log (bytes), named by its path or URI. With
    ``options.stream`` an MCAP file is streamed (memory bounded by the stream's buffers,
    whatever its length), otherwise read into memory; an
    ``s3://bucket/key`` log is downloaded to a temporary file first (:mod:`._s3`)."""
    if _s3.is_s3(entry.log):
        with _s3.local_copy(entry.log) as path:
            return _s3.named(entry.log, path, lambda: _native_stats(entry, path, options))
    return _native_stats(entry, entry.log, options)


def _native_stats(entry: LogEntry, path: str, options: Options) -> bytes:
    return _ivdyn.fleet_log_stats(_robot(entry.model, entry.base, entry.tip), path, entry.log,
                                  topic=options.topic, log_time=options.log_time, cutoff=options.cutoff,
                                  decimate=options.decimate, friction=list(options.friction),
                                  armature=options.armature, offset=options.offset, method=options.method,
                                  stream=options.stream)


def merge(parts: Sequence[bytes]) -> bytes:
    """The statistics of all ``parts`` (statistics of another model are refused, the
    error naming both)."""
    return _ivdyn.fleet_merge(list(parts))


def stats_info(stats: bytes) -> Dict[str, Any]:
    """What statistics hold: ``{"model": fingerprint, "logs": [...], "samples": rows}``."""
    return json.loads(_ivdyn.fleet_stats_info(stats))


def fit(model: str, stats: bytes, options: Options = Options(), *, base: Optional[str] = None,
        tip: Optional[str] = None) -> Dict[str, Any]:
    """The fit of ``stats`` with the URDF ``model``: ``{"report": identify's report (base
    parameters with ``std``, ``fit_report.covariance``, ``params``), "long_run": per-joint
    long-run variance factor of the residual, "logs": [...]}``."""
    return json.loads(_ivdyn.fleet_fit(_robot(model, base, tip), stats, **options._fit_kwargs()))


@dataclasses.dataclass
class FleetResult:
    """What :func:`run` found: per manifest row ``ok`` or the error (``rows``: dicts with
    ``log``, ``robot``, ``period``, ``status``, ``error``); per ``(robot, period)`` the
    merged statistics (``stats``) and the fit (``fits``, as :func:`fit`)."""
    rows: List[Dict[str, Any]]
    stats: Dict[Tuple[str, str], bytes]
    fits: Dict[Tuple[str, str], Dict[str, Any]]
    entries: List[LogEntry] = dataclasses.field(default_factory=list)

    @property
    def failed(self) -> List[Dict[str, Any]]:
        return [r for r in self.rows if r["status"] != "ok"]


def _safe_stats(entry: LogEntry, options: Options) -> Tuple[str, Any]:
    """``("ok", bytes)`` or ``("failed", message)``: a bad log must not stop the run."""
    try:
        return "ok", log_stats(entry, options)
    except Exception as e:  # noqa: BLE001 -- reported on the row, by name
        msg = str(e)
        return "failed", msg if entry.log in msg else f"{entry.log}: {msg}"


def _groups(entries: Sequence[LogEntry], done: Sequence[Tuple[str, Any]]) -> Dict[Tuple[str, str], List[int]]:
    """Indices of the usable logs per (robot, period)."""
    g: Dict[Tuple[str, str], List[int]] = {}
    for i, (e, (status, _)) in enumerate(zip(entries, done)):
        if status == "ok":
            g.setdefault((e.robot, e.period), []).append(i)
    return g


def _safe_fit(e: LogEntry, stats: bytes, options: Options) -> Dict[str, Any]:
    """The fit, or ``{"error": message}`` (too few rows, a singular fit): one group's
    failure must not stop the others."""
    try:
        return fit(e.model, stats, options, base=e.base, tip=e.tip)
    except Exception as ex:  # noqa: BLE001 -- reported on the group
        return {"error": f"{e.robot} {e.period}: {ex}"}


def _rows(entries: Sequence[LogEntry], done: Sequence[Tuple[str, Any]]) -> List[Dict[str, Any]]:
    return [dict(log=e.log, robot=e.robot, period=e.period, payload=e.payload, status=s,
                 error=None if s == "ok" else v) for e, (s, v) in zip(entries, done)]


def run(manifest, options: Options = Options(), *, engine: str = "ray", address: Optional[str] = None,
        num_cpus: Optional[int] = None, progress: Progress = None, fan_in: int = 4) -> FleetResult:
    """Statistics of every log of ``manifest`` (a path, or a list of :class:`LogEntry`),
    merged per (robot, period) in a tree of fan-in ``fan_in``, and fitted. ``engine``:
    ``"ray"`` (``address``/``RAY_ADDRESS`` for a cluster, else a local runtime of
    ``num_cpus`` CPUs, default the machine's) or ``"local"`` (threads, ``num_cpus``).
    ``progress(done, total)`` is called after each log."""
    entries = read_manifest(manifest) if isinstance(manifest, (str, os.PathLike)) else list(manifest)
    if fan_in < 2:
        raise ValueError(f"fan_in must be at least 2, got {fan_in}")
    if engine == "ray":
        from ._ray import run_ray
        done, stats, fits = run_ray(entries, options, address, num_cpus, progress, fan_in)
    elif engine == "local":
        done, stats, fits = _run_local(entries, options, num_cpus, progress, fan_in)
    else:
        raise ValueError(f"engine must be 'ray' or 'local', got {engine!r}")
    return FleetResult(rows=_rows(entries, done), stats=stats, fits=fits, entries=entries)


def _tree(parts: List[Any], fan_in: int, combine: Callable[[List[Any]], Any]) -> Any:
    """Combines ``parts`` ``fan_in`` at a time, level by level, down to one."""
    while len(parts) > 1:
        parts = [combine(parts[i:i + fan_in]) if len(parts[i:i + fan_in]) > 1 else parts[i]
                 for i in range(0, len(parts), fan_in)]
    return parts[0]


def _run_local(entries, options, num_cpus, progress, fan_in):
    total = len(entries)
    with ThreadPoolExecutor(max_workers=num_cpus or os.cpu_count() or 1) as ex:
        futures = [ex.submit(_safe_stats, e, options) for e in entries]
        done = []
        for k, f in enumerate(futures):
            done.append(f.result())
            if progress is not None:
                progress(k + 1, total)
    stats, fits = {}, {}
    for key, idx in _groups(entries, done).items():
        stats[key] = _tree([done[i][1] for i in idx], fan_in, merge)
        fits[key] = _safe_fit(entries[idx[0]], stats[key], options)
    return done, stats, fits


def drift(result: FleetResult, options: Options = Options(), *, q: float = 0.05,
          reference: Optional[Dict[str, str]] = None) -> List[Dict[str, Any]]:
    """Per robot, each period against its reference period (``reference[robot]``, default
    its first period in sorted order): a Wald test per effect on the difference of the two
    fits (``docs/fleet.md``), then Benjamini-Hochberg at false-discovery rate ``q`` across
    every test of the fleet. One dict per test (``robot``, ``period``, ``reference_period``,
    ``reference`` (the reference estimates),
    ``effect``, ``joint``, ``parameters``, ``change``, ``std``, ``statistic``, ``dof``,
    ``p_value``, ``flagged``, ``words``), the flagged ones first, by p-value."""
    rows: List[Dict[str, Any]] = []
    for robot in sorted({r for r, _ in result.stats}):
        periods = sorted(p for r, p in result.stats if r == robot)
        ref = (reference or {}).get(robot, periods[0])
        if (robot, ref) not in result.stats:
            raise ValueError(f"{robot}: reference period {ref!r} has no statistics (periods: {periods})")
        e = next(x for x in result.entries if x.robot == robot)
        native = _robot(e.model, e.base, e.tip)
        for p in periods:
            if p == ref:
                continue
            tests = json.loads(_ivdyn.fleet_drift(native, result.stats[(robot, ref)], result.stats[(robot, p)],
                                                  robot, ref, **options._fit_kwargs()))
            rows.extend(dict(robot=robot, period=p, reference_period=ref, **t) for t in tests)
    flags = _ivdyn.fleet_fdr([r["p_value"] for r in rows], q) if rows else []
    for r, f in zip(rows, flags):
        r["flagged"] = f
    rows.sort(key=lambda r: (not r["flagged"], r["p_value"]))
    return rows


# the latest periods' changes in words, and the report (their own modules)
from .changes import changes  # noqa: E402
from .diagnosis import diagnose  # noqa: E402
from .report import write as write_report  # noqa: E402
