"""``python -m ivdyn.fleet MANIFEST --out DIR``: the fleet run of :func:`ivdyn.fleet.run`
and the drift of :func:`ivdyn.fleet.drift`, written to ``DIR/fleet.json`` (rows, fits,
drift tests, flagged changes in words) and one parameter file per robot and period
(``DIR/params/<robot>_<period>.json``, reloadable with ``--params``). Every file is
written to a temporary name first and moved in place once all are written."""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from typing import Any, Dict, List, Optional

from . import Options, drift, manifest_from_glob, read_manifest, run


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="ivdyn fleet", description=__doc__.split("\n\n")[0])
    p.add_argument("manifest", nargs="?", help="manifest (.csv or .json: log, robot, model, period/time, payload)")
    p.add_argument("--glob", help="log files instead of a manifest (with --rule and --model)")
    p.add_argument("--rule", help="naming rule: a regular expression with (?P<robot>..) and (?P<period>..)")
    p.add_argument("--model", help="URDF of every robot (with --glob)")
    p.add_argument("--base", help="base link (with --glob)")
    p.add_argument("--tip", help="tip link (with --glob)")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--engine", choices=("ray", "local"), default="ray")
    p.add_argument("--address", help="Ray cluster address (default: $RAY_ADDRESS, else a local runtime)")
    p.add_argument("--num-cpus", type=int, help="CPUs of a local runtime (default: the machine's)")
    p.add_argument("--fdr", type=float, default=0.05, help="false-discovery rate of the drift flags")
    p.add_argument("--method", choices=("ols", "wls"), default="wls")
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


def _write_all(files: Dict[str, Any], out: str) -> List[str]:
    """Writes every file (path relative to ``out`` -> JSON value) under temporary names,
    then moves them in place: all or nothing."""
    staged = []
    try:
        for rel, doc in files.items():
            path = os.path.join(out, rel)
            os.makedirs(os.path.dirname(path), exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path), prefix=".ivdyn-")
            staged.append((tmp, path))
            with os.fdopen(fd, "w") as f:
                json.dump(doc, f, indent=1, allow_nan=False, default=str)
    except BaseException:
        for tmp, _ in staged:
            os.unlink(tmp)
        raise
    for tmp, path in staged:
        os.replace(tmp, path)
    return [p for _, p in staged]


def _nan_to_none(x):
    if isinstance(x, float) and x != x:
        return None
    if isinstance(x, dict):
        return {k: _nan_to_none(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_nan_to_none(v) for v in x]
    return x


def main(argv: Optional[List[str]] = None) -> int:
    a = _parser().parse_args(argv)
    opts = Options(method=a.method)
    res = run(_entries(a), opts, engine=a.engine, address=a.address, num_cpus=a.num_cpus,
              progress=None if a.quiet else _bar)
    tests = drift(res, opts, q=a.fdr)
    doc = {
        "rows": res.rows,
        "fits": [dict(robot=r, period=p, **f) for (r, p), f in sorted(res.fits.items())],
        "drift": tests,
        "flagged": [t["words"] for t in tests if t["flagged"]],
        "fdr": a.fdr,
    }
    files = {"fleet.json": _nan_to_none(doc)}
    for (robot, period), f in res.fits.items():
        if "report" in f:
            files[os.path.join("params", f"{robot}_{period}.json")] = _nan_to_none(f["report"]["params"])
    for path in _write_all(files, a.out):
        print(f"written to {path}")
    for r in res.failed:
        print(f"failed: {r['error']}", file=sys.stderr)
    for w in doc["flagged"]:
        print(w)
    return 1 if res.failed else 0


if __name__ == "__main__":
    sys.exit(main())
