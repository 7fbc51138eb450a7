#!/usr/bin/env python3
"""A case set whose nominal URDFs carry the log's friction (docs/diagnose.md, "A URDF that
carries the log's friction").

For every case of SRC (make_cad_cases.py's layout) with Coulomb and/or viscous friction, the
true levels are written into its nominal URDF's `<dynamics friction damping>` on their joints,
and those effects are taken out of the case's truth: the nominal model then holds the friction
(as a URDF written back by `ivdyn identify --write-urdf` does), so the diagnosis should name
only the other effects, and a case left with no effect is a clean log. The logs are not copied
(symlinks to SRC's); `oracle` is kept as it is (its RMS values do not depend on where the
friction is held). Writes OUT/<robot>/{<case>_nominal.urdf, <case>.mcap -> SRC, cases.json}
and OUT/split.json (every case in "tune"; score with score_diagnose_cases.py or by hand).

    .venv/bin/python python/tools/urdf_friction_cases.py /tmp/random_cases /tmp/random_cases_urdf_friction
"""
import argparse
import json
import os
import sys
import xml.etree.ElementTree as ET

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FRICTION = {"coulomb_friction": ("fc", "friction"), "viscous_friction": ("fv", "damping")}


def moved_levels(case):
    """{URDF attribute: {joint: level}} of the case's Coulomb and viscous friction."""
    out = {"friction": {}, "damping": {}}
    for e in case["effects"]:
        if e["name"] in FRICTION:
            key, attr = FRICTION[e["name"]]
            out[attr].update(zip(e["joints"], e["parameters"][key]))
    return out


def write_urdf(src, dst, levels):
    """`src` with each listed joint's `<dynamics>` attributes set to the levels."""
    tree = ET.parse(src)
    for joint in tree.getroot().findall("joint"):
        name = joint.get("name")
        if not any(name in v for v in levels.values()):
            continue
        dyn = joint.find("dynamics")
        if dyn is None:
            dyn = ET.SubElement(joint, "dynamics", damping="0.0", friction="0.0")
        for attr, per_joint in levels.items():
            if name in per_joint:
                dyn.set(attr, repr(float(per_joint[name])))
    tree.write(dst, encoding="utf-8", xml_declaration=True)


def robot_set(src, out, robot):
    """The cases of one arm; returns their ids."""
    m = json.load(open(os.path.join(src, robot, "cases.json")))
    os.makedirs(os.path.join(out, robot), exist_ok=True)
    cases = []
    for c in m["cases"]:
        levels = moved_levels(c)
        if not levels["friction"] and not levels["damping"]:
            continue
        urdf = os.path.join(ROOT, c["urdf"])  # relative: to the repository (fixtures), as make_cad_cases.py writes
        nominal = os.path.abspath(os.path.join(out, robot, f"{c['name']}_nominal.urdf"))
        write_urdf(urdf, nominal, levels)
        log = os.path.join(out, robot, c["log"])
        if not os.path.lexists(log):
            os.symlink(os.path.abspath(os.path.join(src, robot, c["log"])), log)
        effects = [e for e in c["effects"] if e["name"] not in FRICTION]
        cases.append(dict(c, urdf=nominal, effects=effects, friction_in_urdf=levels))
    with open(os.path.join(out, robot, "cases.json"), "w") as f:
        json.dump(dict(m, cases=cases), f, indent=1)
    return [f"{robot}/{c['name']}" for c in cases]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("src", help="a case set of make_cad_cases.py (OUT/<robot>/cases.json)")
    ap.add_argument("out")
    args = ap.parse_args(argv)
    robots = sorted(r for r in os.listdir(args.src) if os.path.isfile(os.path.join(args.src, r, "cases.json")))
    if not robots:
        sys.exit(f"{args.src}: no <robot>/cases.json")
    ids = [i for r in robots for i in robot_set(args.src, args.out, r)]
    with open(os.path.join(args.out, "split.json"), "w") as f:
        json.dump({"tune": ids, "heldout": []}, f, indent=1)
    print(f"{len(ids)} cases with their friction in the nominal URDF")
    return 0


if __name__ == "__main__":
    sys.exit(main())
