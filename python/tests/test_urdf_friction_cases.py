"""python/tools/urdf_friction_cases.py: the log's friction moved into the nominal URDF. The
URDF holds the true levels on their joints, the truth loses them, and the diagnosis of a
fixture case (rarm6_6j/e05_2fx: armature on joints 3 and 4, Coulomb friction on 3, 5 and 6,
MuJoCo's frictionloss) against that URDF names the armature and no friction: the nominal model
holds it, as a URDF written back by identify does."""
import json
import os
import sys
import xml.etree.ElementTree as ET

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
sys.path.insert(0, os.path.join(ROOT, "python", "tools"))
import urdf_friction_cases as ufc  # noqa: E402
import ivdyn  # noqa: E402


def test_friction_moves_into_the_urdf_and_out_of_the_truth(tmp_path):
    src = os.path.join(ROOT, "fixtures", "diagnose_random")
    assert ufc.main([src, str(tmp_path)]) == 0
    split = json.load(open(tmp_path / "split.json"))
    assert "rarm6_6j/e05_2fx" in split["tune"] and "rarm5_7j/e30_2fx" in split["tune"]
    m = json.load(open(tmp_path / "rarm6_6j" / "cases.json"))
    case = next(c for c in m["cases"] if c["name"] == "e05_2fx")
    orig = next(c for c in json.load(open(os.path.join(src, "rarm6_6j", "cases.json")))["cases"]
                if c["name"] == "e05_2fx")
    fc = next(e for e in orig["effects"] if e["name"] == "coulomb_friction")
    dyn = {j.get("name"): j.find("dynamics") for j in ET.parse(case["urdf"]).getroot().findall("joint")}
    for j, v in zip(fc["joints"], fc["parameters"]["fc"]):
        assert float(dyn[j].get("friction")) == v and float(dyn[j].get("damping")) == 0.0
    assert float(dyn["joint_1"].get("friction")) == 0.0
    assert [e["name"] for e in case["effects"]] == ["armature"]

    d = ivdyn.diagnose(case["urdf"], str(tmp_path / "rarm6_6j" / case["log"]), base=m["base"], tip=m["tip"],
                       report=False, verdict=True)
    named = {(e["name"], j) for e in d["effects"] for j in e["joints"]}
    assert named == {("armature", "joint_3"), ("armature", "joint_4")}, d["verdict"]
    assert not any("not the log's" in line for line in d["details"]), d["details"]
