"""Base-parameter names (ivdyn issue 17): the same for every seed and number of random
states, the same from ``base_params`` and from ``identify`` (whose base search uses 200
states), and docs/python.md shows the names the code gives.
"""
import ast
import os
import re

import numpy as np
import pytest

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")


@pytest.fixture(scope="module")
def ur5():
    return ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")


@pytest.mark.parametrize("rigid_only", [False, True])
def test_names_do_not_depend_on_the_random_states(ur5, rigid_only):
    ref = ivdyn.base_params(ur5, rigid_only=rigid_only)
    for samples, seed in [(60, 2), (100, 3), (500, 1), (500, 3)]:
        other = ivdyn.base_params(ur5, samples=samples, seed=seed, rigid_only=rigid_only)
        assert other.names == ref.names, (samples, seed)
        assert other.independent == ref.independent
        # the combinations agree to rounding
        np.testing.assert_allclose(other.K, ref.K, rtol=0, atol=1e-9)


def test_identify_names_its_base_parameters_as_base_params(ur5):
    log = ivdyn.simulate(ur5, duration=4, seed=3, noise=0.05)["log"]
    rep = ivdyn.identify(ur5, log)
    assert [b["name"] for b in rep["base"]] == ivdyn.base_params(ur5).names


def test_python_md_shows_the_names_the_code_gives(ur5):
    """The snippet in docs/python.md: base count and the first names (an entry ending in
    `` + ...`` is a prefix of the name)."""
    text = open(os.path.join(ROOT, "docs", "python.md")).read()
    count = re.search(r"base = ivdyn\.base_params\(robot, samples=100, seed=1\)\s+# (\d+) of (\d+) identifiable", text)
    shown = re.search(r"base\.names\[:2\]\s+# (\[.*\])", text)
    assert count and shown
    base = ivdyn.base_params(ur5, samples=100, seed=1)
    assert (base.base_count, base.full_cols) == (int(count.group(1)), int(count.group(2)))
    for doc, name in zip(ast.literal_eval(shown.group(1)), base.names[:2]):
        assert name.startswith(doc[:-len(" + ...")]) if doc.endswith(" + ...") else name == doc, (doc, name)
