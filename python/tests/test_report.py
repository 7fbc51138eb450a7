"""identify(report=...) and payload(report=...): a self-contained HTML page whose tables
hold the returned report's numbers exactly (each cell's data-v attribute); an unwritable
report path raises and leaves none of the call's files (docs/cli.md, "--report")."""
import base64
import os
import re

import pytest

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def ur5():
    return ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")


def rows(html, table_id):
    """The data-v numbers of each row of the table (header skipped)."""
    body = html[html.index(f'<table id="{table_id}">'):]
    body = body[:body.index("</table>")]
    out = []
    for row in body.split("<tr>")[2:]:
        out.append([float("nan") if v == "null" else float(v) for v in re.findall(r'data-v="([^"]*)"', row)])
    return out


def check_page(html):
    assert html.startswith("<!DOCTYPE html>")
    assert "<script" not in html and "http://" not in html and "https://" not in html
    srcs = re.findall(r'src="([^"]*)"', html)
    assert srcs
    for s in srcs:
        assert s.startswith("data:image/png;base64,")
        assert base64.b64decode(s.split(",", 1)[1])[:8] == PNG_MAGIC
    assert all(h.startswith("#") for h in re.findall(r'href="([^"]*)"', html))


def test_identify_and_payload_reports(ur5, tmp_path):
    before, after = tmp_path / "before.mcap", tmp_path / "after.mcap"
    ivdyn.simulate(ur5, before, duration=10, noise=0.05, seed=1)
    ivdyn.simulate(ur5, after, duration=10, noise=0.05, seed=2, payload_mass=2.0, payload_com=[0.01, -0.02, 0.05])
    rep = ivdyn.identify(ur5, before, report=tmp_path / "i.html")
    html = (tmp_path / "i.html").read_text()
    check_page(html)
    q = rows(html, "quality-table")
    assert len(q) == len(rep["joints"])
    for j, r in enumerate(q):
        assert r[0] == rep["fit"]["rms"][j] and r[1] == rep["fit"]["r2"][j]
        assert r[3] == rep["validation"]["rms"][j] and r[4] == rep["validation"]["r2"][j]
    base = rows(html, "base-table")
    assert [r[0] for r in base] == [b["value"] for b in rep["base"]]
    assert [r[1] for r in base] == [b["std"] for b in rep["base"]]

    pl = ivdyn.payload(ur5, after, before, report=tmp_path / "p.html")
    html = (tmp_path / "p.html").read_text()
    check_page(html)
    est = rows(html, "estimate-table")
    assert est[0][:2] == [pl["mass"], pl["mass_std"]]
    assert [r[0] for r in est[1:4]] == pl["com"]
    # the page lists the inertia in ivdyn's order, the JSON report in URDF's
    assert [r[0] for r in est[4:]] == list(ivdyn.inertia_from_urdf(pl["inertia"]))
    assert [r[:2] for r in rows(html, "quality-table")] == [list(x) for x in zip(pl["rms_before"], pl["rms_after"])]


def test_unwritable_report_leaves_none(ur5, tmp_path):
    log = tmp_path / "log.mcap"
    ivdyn.simulate(ur5, log, duration=8, noise=0.05)
    with pytest.raises(OSError, match="i.html"):
        ivdyn.identify(ur5, log, out_json=tmp_path / "r.json", report=tmp_path / "no" / "i.html")
    assert os.listdir(tmp_path) == ["log.mcap"]
