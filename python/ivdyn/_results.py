"""Readable results for notebooks and terminals: the reports of :func:`ivdyn.identify` and
:func:`ivdyn.payload` as dict subclasses (still ``isinstance(x, dict)``, equal to the JSON
document and JSON-serialisable) with a short ``repr`` (no line over :data:`WIDTH`
characters) and an HTML ``_repr_html_``; the HTML of :class:`ivdyn.FitReport` and
:class:`ivdyn.BaseParams`; and :func:`read_prediction`, the measured / predicted / residual
torques of an identification (``identify(..., prediction=True)``, ``--out-mcap``).
"""
from __future__ import annotations

import html
import math
import os
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from . import _ivdyn

#: Widest line of a result's ``repr`` (the Rust ``FitReport`` text keeps the same bound).
WIDTH = 100
#: Base parameters listed in a ``repr`` (the largest by magnitude); the HTML lists them all.
TOP = 8

# the topics of an identification's prediction file (ivdyn::log::mcap_out, docs/cli.md)
MEASURED_TOPIC = "/ivdyn/measured"
PREDICTED_TOPIC = "/ivdyn/predicted"


def _num(x: Any, spec: str = ".4g") -> str:
    """A number for a table; ``None`` (NaN in the JSON) as ``-``."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if isinstance(x, (int, float, np.floating, np.integer)):
        return format(float(x), spec)
    return str(x)


def _cut(text: str, width: int) -> str:
    """``text`` in at most ``width`` characters (an ellipsis where it was cut)."""
    return text if len(text) <= width else text[: width - 3] + "..."


def _rows_text(headers: Sequence[str], rows: Sequence[Sequence[str]], first: int) -> List[str]:
    """Fixed-width text rows: the first column left-aligned in ``first`` characters, the
    others right-aligned in 12."""
    def line(cells):
        head = _cut(str(cells[0]), first).ljust(first)
        return (head + "".join(f"{_cut(str(c), 12):>13}" for c in cells[1:])).rstrip()
    return [line(headers)] + [line(r) for r in rows]


def html_table(headers: Sequence[str], rows: Sequence[Sequence[Any]], caption: str = "") -> str:
    """An HTML table (every cell escaped)."""
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _notes_html(notes: Sequence[str]) -> str:
    return "" if not notes else "<ul>" + "".join(f"<li>{html.escape(str(n))}</li>" for n in notes) + "</ul>"


class _Report(dict):
    """A JSON report: a dict equal to the document, with a readable ``repr``."""

    def _lines(self) -> List[str]:  # pragma: no cover - every report defines it
        raise NotImplementedError

    def __repr__(self) -> str:
        return "\n".join(_cut(line, WIDTH) for line in self._lines())

    def __str__(self) -> str:
        return self.__repr__()

    def _repr_pretty_(self, p, cycle) -> None:  # IPython's plain-text display
        p.text(self.__repr__())


class IdentifyResult(_Report):
    """The report of :func:`ivdyn.identify` (``docs/cli.md``, "--json (identify)") as a dict.

    ``prediction`` (``identify(..., prediction=True)``, else None): the measured, predicted
    and residual torques of the identified model along the log, from
    :func:`read_prediction`; :mod:`ivdyn.plot` draws them.
    """

    prediction: Optional[Dict[str, Any]] = None

    def _joint_rows(self) -> List[List[str]]:
        fit, val = self.get("fit") or {}, self.get("validation") or {}
        rows = []
        for k, j in enumerate(self.get("joints", [])):
            def at(d, key):
                v = d.get(key)
                return _num(v[k]) if v is not None and k < len(v) else "-"
            rows.append([j, at(fit, "rms"), at(val, "rms"), at(val, "r2")])
        return rows

    def _top(self) -> List[Dict[str, Any]]:
        base = list(self.get("base", []))
        return sorted(base, key=lambda b: -abs(b["value"]) if b.get("value") is not None else 0.0)[:TOP]

    def _lines(self) -> List[str]:
        fit, val = self.get("fit") or {}, self.get("validation") or {}
        head = (f"ivdyn.identify: {self.get('method')}, {len(self.get('joints', []))} joints, "
                f"{fit.get('samples')} samples fitted, {len(self.get('base', []))} base parameters "
                f"(rank {self.get('rank')})")
        out = [head]
        if val:
            out.append(f"validation: {val.get('data')}, {val.get('samples')} samples")
        out += _rows_text(["joint", "RMS fit N m", "RMS valid.", "R2 valid."], self._joint_rows(), 28)
        out.append(f"largest base parameters ({len(self._top())} of {len(self.get('base', []))}; all in ['base']):")
        rows = [[b["name"], _num(b.get("value")), _num(b.get("std"), ".2g"), _num(b.get("rel_std_pct"), ".3g")]
                for b in self._top()]
        out += _rows_text(["name", "value", "std", "rel std %"], rows, WIDTH - 3 * 13)
        if self.get("notes"):
            out.append(f"{len(self['notes'])} note(s) in ['notes']")
        return out

    def _repr_html_(self) -> str:
        fit = self.get("fit") or {}
        title = (f"<p><b>ivdyn.identify</b>: {html.escape(str(self.get('method')))}, "
                 f"{fit.get('samples')} samples fitted, rank {self.get('rank')}</p>")
        joints = html_table(["joint", "RMS fit (N m)", "RMS validation (N m)", "R2 validation"],
                            self._joint_rows(), "residual per joint")
        params = html_table(["base parameter", "value", "std", "rel std %", "nominal"],
                            [[b["name"], _num(b.get("value"), ".6g"), _num(b.get("std"), ".3g"),
                              _num(b.get("rel_std_pct"), ".3g"), _num(b.get("nominal"), ".6g")]
                             for b in self.get("base", [])], "base parameters")
        return title + joints + params + _notes_html(self.get("notes", []))


class PayloadResult(_Report):
    """The report of :func:`ivdyn.payload` (``docs/cli.md``, "--json (payload)") as a dict.
    Its ``inertia`` / ``inertia_std`` keep the JSON file's URDF attribute order
    ``[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]`` (:func:`ivdyn.inertia_from_urdf` for ivdyn's)."""

    def _quantities(self) -> List[List[str]]:
        def vec(x, spec):
            return "-" if x is None else "[" + ", ".join(_num(v, spec) for v in x) + "]"
        return [["mass (kg)", _num(self.get("mass"), ".5g"), _num(self.get("mass_std"), ".2g")],
                ["com (m)", vec(self.get("com"), ".4g"), vec(self.get("com_std"), ".2g")],
                ["inertia (kg m^2; Ixx, Ixy, Ixz, Iyy, Iyz, Izz)", vec(self.get("inertia"), ".3g"),
                 vec(self.get("inertia_std"), ".2g")]]

    def _joint_rows(self) -> List[List[str]]:
        before, after = self.get("rms_before") or [], self.get("rms_after") or []
        return [[j, _num(before[k]) if k < len(before) else "-", _num(after[k]) if k < len(after) else "-"]
                for k, j in enumerate(self.get("joints", []))]

    def _lines(self) -> List[str]:
        out = [f"ivdyn.payload: link {self.get('link')}, nominal {self.get('nominal')}, "
               f"{self.get('samples')} samples, identifiable: {self.get('identifiable')}"]
        if self.get("identifiable"):
            (_, m, m_std), (_, c, c_std), (_, i, i_std) = self._quantities()
            out.append(f"mass     {m} kg (std {m_std})")
            out.append(f"com      {c} m (std {c_std})")
            out.append(f"inertia  {i} kg m^2 about the COM, URDF order Ixx, Ixy, Ixz, Iyy, Iyz, Izz")
            out.append(f"         std {i_std}")
        for h in self.get("not_identifiable", []):
            out.append(f"not identifiable: {h.get('parameter')} (in {h.get('combined_in')})")
        out += _rows_text(["joint", "RMS before", "RMS after"], self._joint_rows(), 28)
        if self.get("notes"):
            out.append(f"{len(self['notes'])} note(s) in ['notes']")
        return out

    def _repr_html_(self) -> str:
        title = (f"<p><b>ivdyn.payload</b>: link {html.escape(str(self.get('link')))}, nominal "
                 f"{html.escape(str(self.get('nominal')))}, {self.get('samples')} samples</p>")
        hidden = [[h.get("parameter"), h.get("combined_in")] for h in self.get("not_identifiable", [])]
        body = (html_table(["quantity", "value", "std"], self._quantities(), "payload")
                if self.get("identifiable") else html_table(["parameter", "combined in"], hidden, "not identifiable"))
        joints = html_table(["joint", "RMS before (N m)", "RMS after (N m)"], self._joint_rows(), "residual")
        return title + body + joints + _notes_html(self.get("notes", []))


def fit_report_html(fit: Any) -> str:
    """The HTML of a :class:`ivdyn.FitReport` (its ``_repr_html_``)."""
    theta, std, rel = fit.theta, fit.std, fit.rel_std_pct
    ls = fit.theta_ls
    headers = ["parameter", "theta", "std", "rel std %"] + (["theta_LS"] if ls is not None else [])
    rows = [[n, _num(theta[k], ".6g"), _num(std[k], ".3g"), _num(rel[k], ".3g")]
            + ([_num(ls[k], ".6g")] if ls is not None else []) for k, n in enumerate(fit.names)]
    title = (f"<p><b>{html.escape(fit.method)} fit</b>: {fit.rows} rows, rank {fit.rank}/{len(fit.names)}, "
             f"sigma2 = {_num(fit.sigma2, '.4e')}, cond(R) = {_num(fit.condition_number, '.3e')}</p>")
    unexcited = _notes_html([f"not excited by this data: {', '.join(fit.unexcited)}"] if fit.unexcited else [])
    return title + html_table(headers, rows) + unexcited


def base_params_html(bp: Any) -> str:
    """The HTML of a :class:`ivdyn.BaseParams` (its ``_repr_html_``)."""
    title = f"<p><b>BaseParams</b>: {bp.base_count} of {bp.full_cols} parameters identifiable</p>"
    return title + html_table(["#", "base parameter"], [[k, n] for k, n in enumerate(bp.names)])


def read_prediction(path: "os.PathLike[str] | str", joint_names: Any) -> Dict[str, Any]:
    """The torques of an identification's prediction file (``identify(out_mcap=...)``,
    ``ivdyn identify --out-mcap``): ``{"t": (T,) s, "joint_names", "q", "qd": (T, N) the
    state the model is evaluated at (smoothed position, differentiated velocity),
    "measured", "predicted", "residual": (T, N) N m}`` (``residual = measured - predicted``,
    as the file's residual topic has it). ``joint_names``: a list or an :class:`ivdyn.Robot`."""
    names = [str(n) for n in getattr(joint_names, "joint_names", joint_names)]
    p = os.fspath(path)
    meas = _ivdyn.read_joint_states(p, names, MEASURED_TOPIC, None)
    pred = _ivdyn.read_joint_states(p, names, PREDICTED_TOPIC, None)
    # the residual topic carries no positions (the log reader needs them); its values are
    # measured - predicted of the two written values, computed the same way here
    return {"t": pred["t"], "joint_names": names, "q": pred["q"], "qd": pred["qd"],
            "measured": meas["tau"], "predicted": pred["tau"], "residual": meas["tau"] - pred["tau"]}
