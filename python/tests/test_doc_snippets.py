"""Every code snippet of README.md and docs/*.md runs (issue 17: docs that cannot rot).

* ```python blocks: the blocks of one file run in order in one namespace (a later block may
  use what an earlier one defined), in a scratch directory;
* ```sh blocks: each block runs as one bash script (`bash -e`: a failing command fails the
  block; a pipeline's status is its last command's, as in a terminal) in a scratch directory, with
  `ivdyn` on the PATH (the debug binary of `cargo test`, or IVDYN_BIN);
* ```rust blocks: compiled and run as doctests (`cargo test`): this test checks that every
  file with one is included by a `#[cfg(doctest)]` item of a crate (below), so a new page
  cannot escape.

The scratch directory links the repository's `fixtures`, `crates`, `docs`, `python` and
`examples` in, so snippets use the paths a reader in a clone would type, and write
their outputs where they do no harm. A block that cannot run here (it needs hardware, a
network or hours) starts with the line `# not run: <why>`; they are counted and listed, and
there are at most MAX_NOT_RUN of them.
"""
import os
import re
import subprocess
import sys

import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
PAGES = ["README.md"] + sorted(os.path.join("docs", f) for f in os.listdir(os.path.join(ROOT, "docs"))
                               if f.endswith(".md"))
LINKED = ("fixtures", "crates", "docs", "python", "examples")
MAX_NOT_RUN = 3
NOT_RUN = "# not run:"
FENCE = re.compile(r"^```([A-Za-z0-9_+-]*)[^\n]*\n(.*?)^```\s*$", re.S | re.M)


def blocks(page, lang):
    """The ```lang blocks of `page`: (line number, code)."""
    text = open(os.path.join(ROOT, page), encoding="utf-8").read()
    return [(text[:m.start()].count("\n") + 1, m.group(2)) for m in FENCE.finditer(text)
            if m.group(1).split(",")[0] == lang]


def scratch(tmp_path):
    for d in LINKED:
        os.symlink(os.path.join(ROOT, d), tmp_path / d)
    return tmp_path


def ivdyn_bin():
    b = os.environ.get("IVDYN_BIN") or os.path.join(ROOT, "target", "debug", "ivdyn")
    if not os.path.exists(b):
        subprocess.run(["cargo", "build", "-q", "-p", "ivdyn-cli", "--bin", "ivdyn"], cwd=ROOT, check=True)
    return b


def runnable(page, lang):
    return [(n, code) for n, code in blocks(page, lang) if not code.startswith(NOT_RUN)]


@pytest.mark.parametrize("page", [p for p in PAGES if runnable(p, "python")])
def test_python_blocks_run(page, tmp_path, monkeypatch):
    monkeypatch.chdir(scratch(tmp_path))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ns = {"__name__": "__snippet__"}
    try:
        for line, code in runnable(page, "python"):
            try:
                exec(compile(code, f"{page}:{line}", "exec"), ns)
            except Exception as e:
                raise AssertionError(f"{page}, the python block at line {line} failed: {e!r}") from e
    finally:
        plt.close("all")


@pytest.mark.parametrize("page", [p for p in PAGES if runnable(p, "sh")])
def test_sh_blocks_run(page, tmp_path):
    bindir = tmp_path / "bin"
    bindir.mkdir()
    os.symlink(ivdyn_bin(), bindir / "ivdyn")
    work = tmp_path / "work"
    work.mkdir()
    scratch(work)
    env = dict(os.environ, PATH=f"{bindir}{os.pathsep}{os.environ['PATH']}")
    for line, code in runnable(page, "sh"):
        r = subprocess.run(["bash", "-e", "-c", code], cwd=work, env=env,
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, f"{page}, the sh block at line {line} exited {r.returncode}:\n{r.stderr[-2000:]}"


def test_rust_blocks_are_doctests():
    """Every page with a ```rust block is included as a doctest by some crate."""
    included = set()
    for crate in ("ivdyn-core", "ivdyn"):
        src = os.path.join(ROOT, "crates", crate, "src")
        text = open(os.path.join(src, "lib.rs"), encoding="utf-8").read()
        for rel in re.findall(r'include_str!\("([^"]+\.md)"\)', text):
            included.add(os.path.relpath(os.path.normpath(os.path.join(src, rel)), ROOT))
    missing = [p for p in PAGES if blocks(p, "rust") and p not in included]
    assert not missing, f"pages with rust blocks not run as doctests: {missing}"


def test_few_blocks_are_not_run():
    skipped = [(p, n) for p in PAGES for lang in ("python", "sh")
               for n, code in blocks(p, lang) if code.startswith(NOT_RUN)]
    assert len(skipped) <= MAX_NOT_RUN, f"blocks marked '{NOT_RUN}': {skipped}"
    # a command block in another language would escape this test
    for p in PAGES:
        for lang in ("bash", "console", "shell", "py"):
            assert not blocks(p, lang), f"{p}: use ```sh or ```python, not ```{lang}"
