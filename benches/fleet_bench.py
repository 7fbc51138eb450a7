"""Fleet throughput, Ray's overhead and memory per worker (issue 18), printed as a table.

    python benches/fleet_bench.py                          # 20 logs of 1 min, 2 rounds
    python benches/fleet_bench.py --logs 100 --minutes 5   # the issue's size (about an hour here)
    python benches/fleet_bench.py --synthetic --arms 10 --days 10 --minutes 5 --rate 500
                                                           # the synthetic fleet: 100 logs of 5 min

Logs: simulated six-joint UR5 logs (base_link to tool0, Fourier excitation, friction,
0.1 N m torque noise) at ``--rate`` Hz as MCAP, ``--per-robot`` logs per robot, made once
into ``--dir`` (not timed). With ``--synthetic``, the synthetic fleet of
``ivdyn.fleet.synth`` instead (``--arms`` x ``--days`` logs, one per arm and day, grouped
per arm and day; base_link to wrist_3_link; each arm's spread, the sensors' quantisation
and the three planted events). Each log is then reduced to its fleet statistics (the
streamed per-log pass; ``--in-memory``: the default pass of ``fleet.Options``, which holds
the log, about 6 kB a sample), merged per group and fitted, by:

* ``identify``: ``ivdyn.identify(stream=True, holdout=0)`` (streamed, unless ``--in-memory``) on each log in turn,
  in this process: the single-log tool on the same logs (a fit per log, no merge);
* ``in-process, 1 thread``: ``fleet.run(engine="local", num_cpus=1)``;
* ``Ray, k workers``: ``fleet.run(engine="ray")`` on a local Ray runtime of ``k`` CPUs
  (its start-up is timed apart and not counted);
* ``in-process, 2 threads``: ``fleet.run(engine="local", num_cpus=2)``.

Every configuration runs ``--repeat`` times, the rounds in alternating order (a load that
drifts favours none), and the fastest round counts. Ray's overhead is its time over the
in-process run's with as many workers. The peak memory
per worker is given twice: the largest peak resident set (``VmHWM``) of the Ray worker
processes, which also counts the shared libraries' pages and the pages of Ray's
shared-memory object store the worker wrote its results into (about 1 MB per log, shared,
not the worker's own), and the largest private memory (``RssAnon``: heap and stacks)
sampled every 50 ms during the run; each beside that of an idle worker (Python, NumPy,
Ray, ivdyn imported). The projection to a cluster scales the per-core rate of the 2-worker Ray run.

Each per-log pass runs its parallel filter on two threads and reads on a third, so on
this 2-core machine one worker already uses more than one core: "per core" below divides
by the machine's cores, not by workers.
"""
from __future__ import annotations

import argparse
import os
import tempfile
import threading
import time

import ivdyn
from ivdyn import fleet

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")
BASE, TIP = "base_link", "tool0"
#: The per-log pass benched (``--in-memory`` sets ``stream`` to False).
OPTIONS = fleet.Options(stream=True)
#: The single-log tool on the same logs, one after another in this process.
IDENTIFY = "identify, one log after another"


def make_logs(d: str, count: int, minutes: float, rate: float, per_robot: int):
    os.makedirs(d, exist_ok=True)
    entries = []
    for k in range(count):
        path = os.path.join(d, f"log{k:04d}_{minutes:g}min_{rate:g}hz.mcap")
        if not os.path.exists(path):
            ivdyn.simulate(UR5, path + ".part.mcap", base=BASE, tip=TIP, duration=60.0 * minutes, rate=rate,
                           seed=k + 1, fc=[2.0, 2.0, 1.5, 0.6, 0.6, 0.4], fv=[0.8, 0.8, 0.5, 0.2, 0.2, 0.1],
                           noise=0.1)
            os.replace(path + ".part.mcap", path)
        entries.append(fleet.LogEntry(log=path, robot=f"arm-{k // per_robot:03d}", model=UR5, period="day0",
                                      base=BASE, tip=TIP))
    return entries


def make_synthetic(d: str, arms: int, days: int, minutes: float, rate: float):
    """The synthetic fleet of ``ivdyn.fleet.synth`` in ``d`` (generated once: kept when its
    manifest is there)."""
    from ivdyn.fleet import synth

    manifest = os.path.join(d, "fleet.csv")
    if not os.path.exists(manifest):
        synth.generate(d, UR5, arms=arms, days=days, minutes=minutes, rate=rate, seed=7, base="base_link",
                       tip="wrist_3_link")
    return fleet.read_manifest(manifest)


def timed(f):
    t = time.perf_counter()
    out = f()
    return time.perf_counter() - t, out


def _descends_from_us(pid: int) -> bool:
    """Whether ``pid`` was started (through any chain of parents) by this process: the
    workers of the Ray runtime this script started, not another session's."""
    me = os.getpid()
    while pid > 1:
        try:
            with open(f"/proc/{pid}/stat") as f:
                pid = int(f.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            return False
        if pid == me:
            return True
    return False


def worker_peaks_mb():
    """Peak and current resident memory (MB) of this runtime's Ray worker processes, and
    their private memory now (``RssAnon``: the heap and stacks, without the shared
    libraries' pages and the pages of Ray's shared-memory object store that ``VmHWM``
    also counts)."""
    out = {}
    for pid in os.listdir("/proc"):
        if not pid.isdigit() or not _descends_from_us(int(pid)):
            continue
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read().split(b"\0")[0].decode(errors="replace")
            if not cmd.startswith("ray::"):
                continue
            with open(f"/proc/{pid}/status") as f:
                st = dict(line.split(":", 1) for line in f if ":" in line)
            mb = {k: int(st[k].split()[0]) / 1024 for k in ("VmHWM", "VmRSS", "RssAnon")}
            out[int(pid)] = (cmd, mb["VmHWM"], mb["VmRSS"], mb["RssAnon"])
        except (OSError, KeyError, ValueError):
            continue
    return out


class AnonSampler:
    """The largest private memory (``RssAnon``, MB) of any Ray worker of this runtime,
    sampled every ``period`` seconds while it runs (the kernel keeps no peak of it). The
    workers are looked up once a second, their status files read at every sample: a few
    file reads, so the sampling costs the timed run next to nothing."""

    def __init__(self, period: float = 0.05):
        self.period, self.peak, self._stop = period, 0.0, threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        pids, found = [], 0.0
        while not self._stop.is_set():
            if time.monotonic() - found > 1.0:
                pids, found = list(worker_peaks_mb()), time.monotonic()
            for pid in pids:
                try:
                    with open(f"/proc/{pid}/status") as f:
                        anon = next(line for line in f if line.startswith("RssAnon:"))
                    self.peak = max(self.peak, int(anon.split()[1]) / 1024)
                except (OSError, StopIteration, ValueError):
                    continue
            self._stop.wait(self.period)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()


def ray_run(entries, cpus: int):
    import ray

    tmp = tempfile.mkdtemp(prefix="ivfb", dir="/tmp")
    from ivdyn.fleet._ray import WORKER_ENV

    # the runtime fleet.run starts (fleet._ray.start), in a private directory
    t_init, _ = timed(lambda: ray.init(num_cpus=cpus, include_dashboard=False, _temp_dir=tmp,
                                       log_to_driver=False, runtime_env={"env_vars": WORKER_ENV}))
    try:
        @ray.remote
        def idle():
            import ivdyn.fleet  # noqa: F401 -- what a statistics worker imports
            return os.getpid()

        # a worker that imported everything but ran no log: its peak is the baseline
        idle_pid = ray.get(idle.remote())
        before = worker_peaks_mb()
        with AnonSampler() as anon:
            t, res = timed(lambda: fleet.run(entries, OPTIONS, engine="ray"))
        peaks = worker_peaks_mb()
    finally:
        ray.shutdown()
    nan = (None, float("nan"), float("nan"), float("nan"))
    baseline = before.get(idle_pid, nan)[1], before.get(idle_pid, nan)[3]
    hwm = max((v[1] for v in peaks.values()), default=float("nan"))
    return t, t_init, res, (hwm, anon.peak), baseline


def check(res, n):
    bad = res.failed
    if bad:
        raise SystemExit(f"{len(bad)} of {n} logs failed: {bad[0]['error']}")


def runs(entries):
    """The configurations: name -> (workers, run returning (seconds, peak note, note))."""
    n = len(entries)

    def identify():
        t, _ = timed(lambda: [ivdyn.identify(e.model, e.log, base=e.base, tip=e.tip, stream=OPTIONS.stream,
                                             holdout=0.0, coulomb="sign") for e in entries])
        return t, "", "streamed" if OPTIONS.stream else "in memory"

    def local(cpus):
        t, res = timed(lambda: fleet.run(entries, OPTIONS, engine="local", num_cpus=cpus))
        check(res, n)
        return t, "", ""

    def on_ray(cpus):
        t, t_init, res, (hwm, anon), (base_hwm, base_anon) = ray_run(entries, cpus)
        check(res, n)
        return t, f"{hwm:.0f} / {anon:.0f} (idle {base_hwm:.0f} / {base_anon:.0f})", f"Ray start {t_init:.1f} s, not counted"

    return {
        IDENTIFY: (1, identify),
        "fleet in-process, 1 thread": (1, lambda: local(1)),
        "fleet on Ray, 1 worker": (1, lambda: on_ray(1)),
        "fleet on Ray, 2 workers": (2, lambda: on_ray(2)),
        "fleet in-process, 2 threads": (2, lambda: local(2)),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--logs", type=int, default=20)
    ap.add_argument("--minutes", type=float, default=1.0)
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--per-robot", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=2,
                    help="rounds, in alternating order (forward, backward, ...); the fastest round counts")
    ap.add_argument("--dir", help="where the logs are made (kept for the next run; default: a folder per "
                    "size under the temporary directory)")
    ap.add_argument("--synthetic", action="store_true",
                    help="the synthetic fleet (ivdyn.fleet.synth): --arms x --days logs")
    ap.add_argument("--days", type=int, default=10, help="days of the synthetic fleet")
    ap.add_argument("--in-memory", action="store_true",
                    help="the in-memory per-log pass (fleet.Options(stream=False)) instead of the streamed one (the default)")
    ap.add_argument("--hours-per-arm", type=float, default=8.0, help="logged hours per arm per day (projection)")
    ap.add_argument("--arms", type=int, default=None,
                    help="arms of the synthetic fleet (default 10); of the projection (default 1000)")
    ap.add_argument("--turnaround-min", type=float, default=10.0)
    a = ap.parse_args()

    global OPTIONS
    OPTIONS = fleet.Options(stream=not a.in_memory)
    tmp = tempfile.gettempdir()
    if a.synthetic:
        arms = a.arms or 10
        d = a.dir or os.path.join(tmp, f"ivdyn-fleet-synth-{arms}x{a.days}-{a.minutes:g}min-{a.rate:g}hz")
        entries = make_synthetic(d, arms, a.days, a.minutes, a.rate)
        a.arms = 1000  # the projection's fleet
    else:
        entries = make_logs(a.dir or os.path.join(tmp, "ivdyn-fleet-bench"), a.logs, a.minutes, a.rate,
                            a.per_robot)
        a.arms = a.arms or 1000
    loads = [os.getloadavg()[0]]
    hours = len(entries) * a.minutes / 60.0
    configs = runs(entries)
    best = {}
    for r in range(a.repeat):
        # alternating order: a load that drifts during the rounds favours no configuration
        for name in (list(configs) if r % 2 == 0 else list(configs)[::-1]):
            secs, peak, note = configs[name][1]()
            if name not in best or secs < best[name][0]:
                best[name] = (secs, peak, note)
            loads.append(os.getloadavg()[0])

    what = "synthetic fleet, " if a.synthetic else ""
    how = "streamed" if OPTIONS.stream else "in memory"
    print(f"\n{what}{len(entries)} logs x {a.minutes:g} min at {a.rate:g} Hz, six joints = {hours:.2f} log-hours, "
          f"per-log pass {how}; "
          f"{os.cpu_count()} cores; fastest of {a.repeat} round(s); load average {min(loads):.1f}-{max(loads):.1f}\n")
    print("| run | workers | seconds | log-hours / s | peak MB per worker: resident / private | note |")
    print("|---|--:|--:|--:|--:|---|")
    for name, (w, _) in configs.items():
        secs, peak, note = best[name]
        print(f"| {name} | {w} | {secs:.1f} | {hours / secs:.3f} | {peak} | {note} |")
    print()
    t = {name: v[0] for name, v in best.items()}
    for k, ray_name, local_name in ((1, "fleet on Ray, 1 worker", "fleet in-process, 1 thread"),
                                    (2, "fleet on Ray, 2 workers", "fleet in-process, 2 threads")):
        print(f"Ray overhead, {k} worker(s): {100.0 * (t[ray_name] / t[local_name] - 1.0):+.1f} % "
              f"against the in-process run with {k} thread(s)")
    print(f"Ray, 1 worker, against the in-process {'streamed ' if OPTIONS.stream else ''}identify on the same logs: "
          f"{100.0 * (t['fleet on Ray, 1 worker'] / t[IDENTIFY] - 1.0):+.1f} % (identify also builds its instrument and "
          "DWH test, and fits each log)")
    per_core = hours / t["fleet on Ray, 2 workers"] / (os.cpu_count() or 2)
    day = a.arms * a.hours_per_arm
    cores = day / (per_core * 60.0 * a.turnaround_min)
    print(f"\nProjection (not measured): {per_core * 3600:.0f} log-hours per core-hour on this machine's cores "
          f"(Ray, 2 workers, {os.cpu_count()} cores); a {a.arms}-arm fleet logging {a.hours_per_arm:g} h a day "
          f"at {a.rate:g} Hz = {day:.0f} log-hours a day, i.e. {day / per_core / 3600:.0f} core-hours, "
          f"{cores:.0f} such cores for a {a.turnaround_min:g}-minute turnaround (no I/O limit, no scheduling "
          f"overhead beyond what was measured here).")


if __name__ == "__main__":
    main()
