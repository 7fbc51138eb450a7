"""The fleet report (issue 18, item 4): ``report.json`` for machines, ``fleet.html`` for
people, and a parameter file per robot, written whole or not at all (:func:`write`).

``fleet.html`` is one self-contained page (inline style sheet and SVG figures, no script,
nothing loaded from elsewhere): the changes in words (flagged robots first), what the diagnosis names (with
:func:`ivdyn.fleet.diagnose`), a heat map
of robots x parameters (the standardised drift of each robot's latest period against its
reference: ``change / std`` for one parameter, the normal score of the Wald statistic for
a group), and per robot the trends of its changed parameters (the estimate per period
with its 95 % confidence band).
"""
from __future__ import annotations

import html
import json
import math
import os
import tempfile
from typing import Any, Dict, List, Optional, Sequence, Tuple

from .changes import changes as latest_changes
from .changes import effect_key

__all__ = ["fleet_doc", "heatmap", "page", "write"]

#: Colour scale of the heat map: |z| at or above this is full colour.
Z_FULL = 10.0
#: Trends shown per robot at most (its changes first).
MAX_TRENDS = 6


def _nan_to_none(x):
    if isinstance(x, float) and x != x:
        return None
    if isinstance(x, dict):
        return {k: _nan_to_none(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_nan_to_none(v) for v in x]
    return x


def _z(t: Dict[str, Any]) -> float:
    """The standardised drift of a test: ``change / std`` for one parameter; for a group,
    the Wilson-Hilferty normal score of its chi-square statistic (about N(0, 1) under no
    change, whatever the degrees of freedom)."""
    if len(t["change"]) == 1:
        s = t["std"][0]
        return t["change"][0] / s if s > 0 else 0.0
    k, x = t["dof"], t["statistic"]
    if k == 0:
        return 0.0
    a = 2.0 / (9.0 * k)
    return ((x / k) ** (1.0 / 3.0) - (1.0 - a)) / math.sqrt(a)


def _column(t: Dict[str, Any]) -> str:
    return t["parameters"][0] if len(t["parameters"]) == 1 else t["effect"]


#: Column order of the heat map: per joint (base to tip) these effects, then the groups.
EFFECTS = ("coulomb_friction", "viscous_friction", "armature", "torque_offset")
GROUPS = ("payload", "rigid_body")


def _column_key(t: Dict[str, Any], joints: Sequence[str]) -> Tuple[int, int]:
    if t["effect"] in GROUPS:
        return len(joints), GROUPS.index(t["effect"])
    j = joints.index(t["joint"]) if t.get("joint") in joints else len(joints)
    return j, EFFECTS.index(t["effect"]) if t["effect"] in EFFECTS else len(EFFECTS)


def _robot_order(tests: Sequence[Dict[str, Any]], robots: Sequence[str]) -> List[str]:
    """Robots with a change on their latest period first (smallest p-value first), then
    the rest by name."""
    best: Dict[str, float] = {}
    for c in latest_changes(tests):
        best[c["robot"]] = min(best.get(c["robot"], 1.0), c["test"]["p_value"])
    return sorted(robots, key=lambda r: (r not in best, best.get(r, 0.0), r))


def heatmap(tests: Sequence[Dict[str, Any]], robots: Sequence[str], joints: Sequence[str] = ()) -> Dict[str, Any]:
    """Robots x parameters (``columns``: per joint of ``joints``, then the groups) of the
    standardised drift (``z``, ``None`` where a robot has no such test) of each robot's
    latest period, and which are ``flagged``."""
    latest = {r: max((t["period"] for t in tests if t["robot"] == r), default=None) for r in robots}
    keys: Dict[str, Tuple[int, int]] = {}
    cell: Dict[Tuple[str, str], Dict[str, Any]] = {}
    for t in tests:
        if t["period"] != latest[t["robot"]]:
            continue
        keys.setdefault(_column(t), _column_key(t, joints))
        cell[(t["robot"], _column(t))] = t
    cols = sorted(keys, key=lambda c: keys[c])
    order = _robot_order(tests, robots)
    z = [[None if (r, c) not in cell else _z(cell[(r, c)]) for c in cols] for r in order]
    flagged = [[bool(cell.get((r, c), {}).get("flagged")) for c in cols] for r in order]
    return {"robots": order, "periods": [latest[r] for r in order], "columns": cols, "z": z, "flagged": flagged}


def _joints(result) -> List[str]:
    return next((f["report"]["params"]["joints"] for f in result.fits.values() if "report" in f), [])


def _slim(f: Dict[str, Any]) -> Dict[str, Any]:
    """A fit without its covariance and report details: the base estimates, the long-run
    factors, the parameter file and the logs' count (the report's JSON)."""
    if "report" not in f:
        return f
    base = [{k: b[k] for k in ("name", "value", "std")} for b in f["report"]["base"]]
    return {"base": base, "long_run": f["long_run"], "params": f["report"]["params"], "logs": len(f["logs"])}


def _slim_diagnosis(d: Dict[str, Any]) -> Dict[str, Any]:
    """A diagnosis without the payload's full report (its mass, std and why stay)."""
    if not d.get("payload"):
        return d
    return dict(d, payload={k: v for k, v in d["payload"].items() if k != "report"})


def fleet_doc(result, tests: Sequence[Dict[str, Any]], fdr: float, slim: bool = False,
              diagnoses: Optional[Sequence[Dict[str, Any]]] = None) -> Dict[str, Any]:
    """``fleet.json``: the manifest rows, the fits (``slim``: without covariances), every
    drift test, the flagged tests in words, the changes of the latest periods, the heat
    map, and with ``diagnoses`` (:func:`ivdyn.fleet.diagnose`) what the diagnosis names
    (``diagnoses``, ``named``: their words)."""
    robots = sorted({r for r, _ in result.fits})
    ch = latest_changes(tests)
    named = {} if diagnoses is None else {
        "diagnoses": [_slim_diagnosis(d) if slim else d for d in diagnoses],
        "named": [w for d in diagnoses for w in d["words"]],
    }
    return _nan_to_none({
        "rows": result.rows,
        "fits": [dict(robot=r, period=p, **(_slim(f) if slim else f)) for (r, p), f in sorted(result.fits.items())],
        "drift": list(tests),
        "flagged": [t["words"] for t in tests if t["flagged"]],
        "changes": [{k: v for k, v in c.items() if k != "test"} for c in ch],
        "heatmap": heatmap(tests, robots, _joints(result)),
        "fdr": fdr,
        **named,
    })


def _base_series(result, robot: str, name: str) -> List[Tuple[str, float, float]]:
    """``(period, value, std)`` of base parameter ``name`` in every fit of ``robot``, the
    standard deviation scaled as the drift test scales it (the largest long-run factor)."""
    out = []
    for (r, p), f in sorted(result.fits.items()):
        if r != robot or "report" not in f:
            continue
        c = max([1.0] + [x for x in f.get("long_run", []) if x is not None and x == x])
        for b in f["report"]["base"]:
            if b["name"] == name and b["value"] is not None and b["std"] is not None:
                out.append((p, b["value"], b["std"] * math.sqrt(c)))
    return out


def _trend_svg(title: str, series: List[Tuple[str, float, float]], reference: str, flagged: set) -> str:
    """A small inline SVG: the estimate per period, its 95 % band, the reference period's
    value dashed, flagged periods in red."""
    w, h, l, r, t, b = 380, 170, 62, 12, 22, 30
    lo = [v - 1.96 * s for _, v, s in series]
    hi = [v + 1.96 * s for _, v, s in series]
    y0, y1 = min(lo), max(hi)
    if y1 - y0 <= 0:
        y0, y1 = y0 - 1.0, y1 + 1.0
    pad = 0.08 * (y1 - y0)
    y0, y1 = y0 - pad, y1 + pad
    k = max(len(series) - 1, 1)

    def x(i: int) -> float:
        return l + (w - l - r) * i / k

    def y(v: float) -> float:
        return t + (h - t - b) * (y1 - v) / (y1 - y0)

    band = " ".join(f"{x(i):.1f},{y(v):.1f}" for i, v in enumerate(hi))
    band += " " + " ".join(f"{x(i):.1f},{y(v):.1f}" for i, v in reversed(list(enumerate(lo))))
    line = " ".join(f"{x(i):.1f},{y(v):.1f}" for i, (_, v, _) in enumerate(series))
    ref = next((v for p, v, _ in series if p == reference), None)
    e = html.escape
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" '
             f'role="img"><title>{e(title)}</title>',
             f'<text x="{l}" y="14" font-size="12">{e(title)}</text>',
             f'<rect x="{l}" y="{t}" width="{w - l - r}" height="{h - t - b}" fill="none" stroke="#d5dbe3"/>',
             f'<polygon points="{band}" fill="#9cc3e6" fill-opacity="0.5"/>',
             f'<polyline points="{line}" fill="none" stroke="#1f4e79" stroke-width="1.5"/>']
    if ref is not None:
        parts.append(f'<line x1="{l}" x2="{w - r}" y1="{y(ref):.1f}" y2="{y(ref):.1f}" stroke="#5b6675" '
                     'stroke-dasharray="4 3"/>')
    for i, (p, v, _) in enumerate(series):
        color = "#c0392b" if p in flagged else "#1f4e79"
        parts.append(f'<circle cx="{x(i):.1f}" cy="{y(v):.1f}" r="3" fill="{color}"><title>{e(p)}: {v:.4g}'
                     '</title></circle>')
    for v in (y0 + pad, y1 - pad):
        parts.append(f'<text x="{l - 4}" y="{y(v) + 4:.1f}" font-size="10" text-anchor="end">{v:.3g}</text>')
    for i in sorted({0, len(series) - 1}):
        parts.append(f'<text x="{x(i):.1f}" y="{h - 10}" font-size="10" text-anchor="middle">'
                     f'{e(series[i][0])}</text>')
    parts.append("</svg>")
    return "".join(parts)


CSS = """
body { font-family: "DejaVu Sans", system-ui, Helvetica, Arial, sans-serif; color: #1d232b; margin: 0;
       background: #f7f8fa; line-height: 1.45; }
main { max-width: 1180px; margin: 0 auto; padding: 24px 28px 60px; background: #fff; }
h2 { border-bottom: 2px solid #d5dbe3; padding-bottom: 4px; margin-top: 34px; }
.sub, .note, footer { color: #5b6675; }
table { border-collapse: collapse; font-size: 13px; }
th, td { border: 1px solid #d5dbe3; padding: 2px 5px; }
th { background: #eef2f7; text-align: left; }
table.heat th.col { writing-mode: vertical-rl; transform: rotate(180deg); white-space: nowrap; font-weight: 500; }
table.heat td { min-width: 22px; text-align: center; font-size: 11px; }
table.heat td.flag { outline: 2px solid #1d232b; font-weight: bold; }
li.change { font-size: 17px; margin: 4px 0; }
figure { display: inline-block; margin: 6px 10px 10px 0; }
"""


def _color(z: Optional[float]) -> str:
    """White at 0, red for an increase, blue for a decrease (full at :data:`Z_FULL`)."""
    if z is None:
        return "#f0f0f0"
    a = min(abs(z) / Z_FULL, 1.0)
    hi, lo = (192, 57, 43) if z >= 0 else (41, 98, 180), 255
    return "#" + "".join(f"{round(lo + a * (c - lo)):02x}" for c in hi)


def _heat_table(hm: Dict[str, Any]) -> str:
    e = html.escape
    out = ['<table class="heat" id="heatmap-table"><tr><th>robot</th><th>period</th>']
    out += [f'<th class="col">{e(c)}</th>' for c in hm["columns"]]
    out.append("</tr>")
    for r, p, zs, fs in zip(hm["robots"], hm["periods"], hm["z"], hm["flagged"]):
        out.append(f'<tr data-robot="{e(r)}"><th>{e(r)}</th><td>{e(p or "")}</td>')
        for c, z, f in zip(hm["columns"], zs, fs):
            val = "" if z is None else f"{z:.0f}" if abs(z) >= 10 else f"{z:.1f}"
            zattr = "null" if z is None else repr(z)
            out.append(f'<td style="background:{_color(z)}" class="{"flag" if f else ""}" data-z="{zattr}" '
                       f'title="{e(r)}, {e(c)}: z = {val}">{val}</td>')
        out.append("</tr>")
    out.append("</table>")
    return "".join(out)


def _trends(result, tests: Sequence[Dict[str, Any]], robot: str) -> List[str]:
    """The figures of ``robot``: the parameters of its changes, else its largest drift."""
    rows = [t for t in tests if t["robot"] == robot]
    if not rows:
        return []
    latest = max(t["period"] for t in rows)
    last = sorted((t for t in rows if t["period"] == latest), key=lambda t: (not t["flagged"], t["p_value"]))
    chosen = [t for t in last if t["flagged"]] or last[:1]
    names: List[str] = []
    for t in chosen:  # the parameters of a group: its largest standardised changes
        ranked = sorted(range(len(t["parameters"])), key=lambda i: -abs(t["change"][i] / (t["std"][i] or 1.0)))
        names += [t["parameters"][i] for i in ranked[:3] if t["parameters"][i] not in names]
    figs = []
    for name in names[:MAX_TRENDS]:
        t = next(x for x in chosen if name in x["parameters"])
        key = effect_key(t)
        flagged = {x["period"] for x in rows if x["flagged"] and effect_key(x) == key}
        series = _base_series(result, robot, name)
        if len(series) >= 2:
            figs.append(_trend_svg(name, series, t["reference_period"], flagged))
    return figs


def page(result, tests: Sequence[Dict[str, Any]], doc: Dict[str, Any]) -> str:
    """``fleet.html`` (module docstring) of a fleet run, its drift tests and its
    :func:`fleet_doc`."""
    e = html.escape
    hm = doc["heatmap"]
    failed = [r for r in doc["rows"] if r["status"] != "ok"]
    o = ['<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>ivdyn fleet report</title>',
         f"<style>{CSS}</style></head><body><main>", "<h1>Fleet report</h1>",
         f'<p class="sub">{len(hm["robots"])} robots, {len(doc["fits"])} fits of (robot, period), '
         f'{len(doc["rows"])} logs ({len(failed)} failed); drift flagged at false-discovery rate '
         f'{doc["fdr"]:g} across {len(tests)} tests.</p>', '<h2 id="changes">What changed</h2>']
    if doc["changes"]:
        o.append('<ol id="changes-list">')
        o += [f'<li class="change" data-robot="{e(c["robot"])}">{e(c["words"])}</li>' for c in doc["changes_ordered"]]
        o.append("</ol>")
    else:
        o.append('<p id="changes-list">No change flagged on any robot\'s latest period.</p>')
    if "diagnoses" in doc:
        o += ['<h2 id="named">What the diagnosis names</h2>',
              "<p class=\"note\">Each changed robot's latest log diagnosed against its reference period's model "
              "(the effects it misses, 95 % intervals), and the payload's mass when its drift is flagged.</p>"]
        o.append('<ul id="named-list">')
        o += [f'<li class="named" data-robot="{e(d["robot"])}">{e(w)}</li>'
              for d in doc["diagnoses"] for w in d["words"]]
        o.append("</ul>")
    o += ['<h2 id="heatmap">Standardised drift of the latest period</h2>',
          '<p class="note">Each robot\'s latest period against its reference: change / std for one parameter '
          "(red: up, blue: down), the normal score of the Wald statistic for a group; outlined: flagged.</p>",
          _heat_table(hm), '<h2 id="robots">Robots</h2>',
          '<p class="note">Per period the estimate (line) and its 95 % confidence band; dashed: the reference '
          "period's value; red points: periods where the effect is flagged.</p>"]
    for r in hm["robots"]:
        o.append(f'<section class="robot" data-robot="{e(r)}"><h3 id="robot-{e(r)}">{e(r)}</h3>')
        o += [f"<figure>{svg}</figure>" for svg in _trends(result, tests, r)]
        o.append("</section>")
    if failed:
        o.append('<h2 id="failed">Failed logs</h2><ul>')
        o += [f"<li>{e(str(r['error']))}</li>" for r in failed]
        o.append("</ul>")
    o.append("<footer>Written by ivdyn fleet (docs/fleet.md).</footer></main></body></html>\n")
    return "\n".join(o)


def _stage(files: Dict[str, str], staged: List[Tuple[str, str]]) -> None:
    mask = os.umask(0)
    os.umask(mask)
    for path, text in files.items():
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(path)), prefix=".ivdyn-")
        staged.append((tmp, path))
        os.chmod(tmp, 0o666 & ~mask)  # mkstemp's 0600 is for the temporary name only
        with os.fdopen(fd, "w") as f:
            f.write(text)


def write_all(files: Dict[str, str]) -> List[str]:
    """Writes every file (path -> text) under a temporary name beside it, then moves them
    in place: all or nothing."""
    staged: List[Tuple[str, str]] = []
    try:
        _stage(files, staged)
    except BaseException:
        for tmp, _ in staged:
            os.unlink(tmp)
        raise
    for tmp, path in staged:
        os.replace(tmp, path)
    return [p for _, p in staged]


def _json(doc: Any) -> str:
    return json.dumps(_nan_to_none(doc), indent=1, allow_nan=False, default=str) + "\n"


def write(result, tests: Sequence[Dict[str, Any]], *, out: Optional[str] = None, report: Optional[str] = None,
          fdr: float = 0.05, diagnoses: Optional[Sequence[Dict[str, Any]]] = None) -> List[str]:
    """Writes the fleet's outputs, all or nothing. ``out``: ``fleet.json`` and a parameter
    file per robot and period (``params/<robot>_<period>.json``); ``report``: ``fleet.html``,
    ``report.json`` (``fleet.json`` with the fits slimmed: no covariances) and a parameter
    file per robot, its latest period's
    (``params/<robot>.json``). Parameter files reload with ``--params`` / ``params=``.
    ``diagnoses`` (:func:`ivdyn.fleet.diagnose`): what the diagnosis names, in both."""
    files: Dict[str, str] = {}
    if out is not None:
        files[os.path.join(out, "fleet.json")] = _json(fleet_doc(result, tests, fdr, diagnoses=diagnoses))
        for (robot, period), f in result.fits.items():
            if "report" in f:
                files[os.path.join(out, "params", f"{robot}_{period}.json")] = _json(f["report"]["params"])
    if report is not None:
        doc = fleet_doc(result, tests, fdr, slim=True, diagnoses=diagnoses)
        order = {r: i for i, r in enumerate(doc["heatmap"]["robots"])}
        doc_html = dict(doc, changes_ordered=sorted(doc["changes"], key=lambda c: order[c["robot"]]))
        files[os.path.join(report, "fleet.html")] = page(result, tests, doc_html)
        files[os.path.join(report, "report.json")] = _json(doc)
        for robot in order:
            fits = sorted((p, f) for (r, p), f in result.fits.items() if r == robot and "report" in f)
            if fits:
                files[os.path.join(report, "params", f"{robot}.json")] = _json(fits[-1][1]["report"]["params"])
    return write_all(files)
