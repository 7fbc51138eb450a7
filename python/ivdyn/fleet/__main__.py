"""``python -m ivdyn.fleet MANIFEST --out DIR --report DIR``: the fleet run of
:func:`ivdyn.fleet.run` and the drift of :func:`ivdyn.fleet.drift`, written by
:func:`ivdyn.fleet.report.write`: ``--out``: ``fleet.json`` (rows, fits, drift tests,
flagged changes in words, the latest changes, the heat map) and one parameter file per
robot and period (``params/<robot>_<period>.json``, reloadable with ``--params``), and what
the diagnosis names on the changed robots' latest logs (:func:`ivdyn.fleet.diagnose`);
``--report``: ``fleet.html``, ``fleet.json`` and one parameter file per robot (its latest
period). Every file is written to a temporary name first and moved in place once all are
written."""
from __future__ import annotations

import argparse
import sys
from typing import List, Optional

from . import Options, diagnose, drift, manifest_from_glob, read_manifest, run
from .report import write


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="ivdyn fleet", description=__doc__.split("\n\n")[0])
    p.add_argument("manifest", nargs="?", help="manifest (.csv or .json: log, robot, model, period/time, payload)")
    p.add_argument("--glob", help="log files instead of a manifest (with --rule and --model)")
    p.add_argument("--rule", help="naming rule: a regular expression with (?P<robot>..) and (?P<period>..)")
    p.add_argument("--model", help="URDF of every robot (with --glob)")
    p.add_argument("--base", help="base link (with --glob)")
    p.add_argument("--tip", help="tip link (with --glob)")
    p.add_argument("--out", help="output directory: fleet.json and a parameter file per robot and period")
    p.add_argument("--report", help="report directory: fleet.html, fleet.json and a parameter file per robot")
    p.add_argument("--engine", choices=("ray", "local"), default="ray")
    p.add_argument("--address", help="Ray cluster address (default: $RAY_ADDRESS, else a local runtime)")
    p.add_argument("--num-cpus", type=int, help="CPUs of a local runtime (default: the machine's)")
    p.add_argument("--fdr", type=float, default=0.05, help="false-discovery rate of the drift flags")
    p.add_argument("--method", choices=("ols", "wls"), default="wls")
    p.add_argument("--in-memory", action="store_true",
                   help="read every log into memory instead of streaming MCAP logs (docs/fleet.md, Memory)")
    p.add_argument("--no-diagnosis", action="store_true",
                   help="do not diagnose the changed robots' latest logs against their reference models")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p


def _entries(a: argparse.Namespace):
    if a.glob:
        if not (a.rule and a.model):
            raise SystemExit("ivdyn fleet: --glob needs --rule and --model")
        return manifest_from_glob(a.glob, a.rule, a.model, base=a.base, tip=a.tip)
    if not a.manifest:
        raise SystemExit("ivdyn fleet: give a manifest or --glob")
    return read_manifest(a.manifest)


def _bar(done: int, total: int) -> None:
    width = 30
    k = width * done // max(total, 1)
    sys.stderr.write(f"\rlogs [{'#' * k}{'.' * (width - k)}] {done}/{total}")
    if done == total:
        sys.stderr.write("\n")
    sys.stderr.flush()


def main(argv: Optional[List[str]] = None) -> int:
    a = _parser().parse_args(argv)
    if a.out is None and a.report is None:
        raise SystemExit("ivdyn fleet: give --out DIR, --report DIR or both")
    opts = Options(method=a.method, stream=not a.in_memory)
    res = run(_entries(a), opts, engine=a.engine, address=a.address, num_cpus=a.num_cpus,
              progress=None if a.quiet else _bar)
    tests = drift(res, opts, q=a.fdr)
    named = None if a.no_diagnosis else diagnose(res, tests, engine=a.engine, address=a.address,
                                                 num_cpus=a.num_cpus)
    for path in write(res, tests, out=a.out, report=a.report, fdr=a.fdr, diagnoses=named):
        print(f"written to {path}")
    for r in res.failed:
        print(f"failed: {r['error']}", file=sys.stderr)
    for t in tests:
        if t["flagged"]:
            print(t["words"])
    for w in [w for d in named or [] for w in d["words"]]:
        print(f"named: {w}")
    return 1 if res.failed else 0


if __name__ == "__main__":
    sys.exit(main())
