"""pandas DataFrames as logs: the CSV layout ivdyn reads (``docs/logs.md``, "CSV input"),
one row per sample, columns ``t`` (s), ``<joint>.q`` (every joint), and optionally
``<joint>.qd``, ``.tau``, ``.u``, ``.i`` (motor current, A) for every joint; other columns
are ignored. pandas is never imported here: a DataFrame is recognised by its type's module
and used through ``columns``, ``index``, ``__getitem__`` and ``to_numpy`` only, so pandas
stays an optional dependency.
"""
from __future__ import annotations

from typing import Any, Dict, Sequence

# the log dict's key and the CSV column suffix of each per-joint field
_FIELDS = (("q", "q"), ("qd", "qd"), ("tau", "tau"), ("u", "u"), ("current", "i"))


def is_frame(x: Any) -> bool:
    """Whether ``x`` is a pandas DataFrame (without importing pandas)."""
    mod = type(x).__module__ or ""
    return mod.split(".")[0] == "pandas" and hasattr(x, "columns") and hasattr(x, "to_numpy")


def _listed(names: Sequence[str], most: int = 12) -> str:
    """``names`` for a message, the first ``most`` of a long list."""
    names = list(names)
    more = f", ... ({len(names)} columns)" if len(names) > most else ""
    return "[" + ", ".join(names[:most]) + more + "]"


def frame_log(df: Any, joints: Sequence[str], what: str) -> Dict[str, Any]:
    """The log dict of DataFrame ``df`` for ``joints`` (base to tip); ``ValueError`` naming
    ``what`` and the missing columns and joints."""
    cols = [str(c) for c in df.columns]
    if len(set(cols)) != len(cols):
        dup = sorted({c for c in cols if cols.count(c) > 1})
        raise ValueError(f"{what}: the DataFrame has repeated columns {_listed(dup)}")
    have = set(cols)
    if "t" in have:
        t = df["t"].to_numpy()
    elif getattr(df.index, "name", None) == "t":
        t = df.index.to_numpy()
    else:
        raise ValueError(f"{what}: the DataFrame has no column 't' (time in seconds; an index named 't' "
                         f"also works); its columns are {_listed(cols)}")
    out: Dict[str, Any] = {"t": t, "joint_names": [str(j) for j in joints]}
    for key, suffix in _FIELDS:
        wanted = [f"{j}.{suffix}" for j in joints]
        missing = [c for c in wanted if c not in have]
        if len(missing) == len(wanted) and key != "q":
            continue  # an optional field the log does not have
        if missing:
            lacking = [j for j, c in zip(joints, wanted) if c in missing]
            why = "" if key == "q" else f" (a field is read when every joint has it: '.{suffix}' is there for others)"
            raise ValueError(f"{what}: columns {_listed(missing)} are missing (joints {_listed(lacking)}){why}; "
                             f"the DataFrame has {_listed(cols)}")
        out[key] = df[wanted].to_numpy()
    return out
