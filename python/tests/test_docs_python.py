"""Every ```python block of docs/python.md runs, in order, in one namespace (the page reads
as one session), in a temporary folder where ``fixtures/`` is the repository's. A block
that cannot run on purpose is preceded by a line ``<!-- not run: why -->``; at most
:data:`MAX_NOT_RUN` of them."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "python.md"
MAX_NOT_RUN = 1
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def blocks():
    """``(line, code, runs)`` of every python block of the page."""
    text = DOC.read_text()
    out = []
    for m in BLOCK.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        before = text[: m.start()].rstrip().splitlines()[-1:] or [""]
        out.append((line, m.group(1), not before[0].startswith("<!-- not run")))
    return out


def test_the_page_has_its_blocks_and_few_are_not_run():
    b = blocks()
    assert len(b) >= 10, f"{len(b)} python blocks found in {DOC}"
    assert sum(not runs for _, _, runs in b) <= MAX_NOT_RUN


def test_every_python_block_of_python_md_runs(tmp_path, monkeypatch):
    pytest.importorskip("pandas")
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    (tmp_path / "fixtures").symlink_to(ROOT / "fixtures")
    monkeypatch.chdir(tmp_path)
    ns: dict = {"__name__": "docs_python"}
    try:
        for line, code, runs in blocks():
            if not runs:
                continue
            try:
                exec(compile(code, f"{DOC}:{line}", "exec"), ns)
            except Exception as e:  # the block's line in the message, not only the exec's
                pytest.fail(f"docs/python.md, the block at line {line} fails: {type(e).__name__}: {e}")
    finally:
        plt.close("all")
