"""Randomly generated serial arms for the MuJoCo hidden-effect cases (issue 15, item 5).

An arm of `n` revolute joints is drawn from a seed: DH-like kinematics (modified DH,
Craig's convention: joint i sits at Tx(a) Rx(alpha) Tz(d) of the previous link's frame and
turns about its own z axis) and inertials within physical bounds. It is written twice,
from the same numbers and by two independent writers:

* a URDF (`base_link` fixed root, links `link_1..n`, joints `joint_1..n`), which ivdyn loads
  and from which the nominal models with inertial errors are derived
  (make_diagnose_cases.scale_inertials);
* an MJCF (bodies `link_1..n` with `fullinertia`), the truth MuJoCo simulates.

Kinematics: twists alpha from {0, +-pi/2} mostly (the usual orthogonal and parallel axes),
sometimes any angle; link lengths a and offsets d of 0-0.45 m, rescaled so that the sum of
|a| + |d| (the reach along the chain) is 0.7-1.4 m; no two consecutive axes coincide
(alpha = 0 needs a >= 5 cm) and every link has length >= 5 cm.

Inertials (checked by `check_inertials`): link i is a solid box along the segment from its
origin to the next joint (the last link: to a flange 5-15 cm along its z axis), of width
and height 1.2-2.4 times a radius of 3-8 cm (thinner along the chain); mass 0.3-15 kg
(about 2 + 20 kg per m of length, tapering towards the tip); the inertia about the COM is
that box's, turned with the box, so its principal moments satisfy the triangle
inequalities strictly; the COM lies on the segment (20-80 % of its length) with a lateral
offset within half the radius, so inside the box.
"""
import math
import xml.etree.ElementTree as ET

import numpy as np

REACH = (0.7, 1.4)          # m, sum of |a| + |d| over the chain
MIN_LEN = 0.05              # m
FLANGE = (0.05, 0.15)       # m, last link's length along its z axis
RADIUS = (0.03, 0.08)       # m
MASS = (0.3, 15.0)          # kg
JOINT_LIMIT = 3.1           # rad (URDF <limit>; the reference stays >= 0.2 rad inside)
VEL_LIMIT = 3.5             # rad/s


def rot_x(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def draw_kinematics(n, rng):
    """[(a, alpha, d)] per joint: joint i's origin is Tx(a) Rx(alpha) Tz(d) in link i-1."""
    rows = []
    for i in range(n):
        if i == 0:          # the first axis is vertical, above the base
            rows.append([0.0, 0.0, float(rng.uniform(0.1, 0.35))])
            continue
        u = rng.random()
        alpha = (math.pi / 2 if u < 0.4 else -math.pi / 2 if u < 0.8 else 0.0 if u < 0.9
                 else float(rng.uniform(-math.pi, math.pi)))
        a = float(rng.uniform(0.0, 0.45)) if rng.random() < 0.5 else 0.0
        d = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.0, 0.4)) if rng.random() < 0.6 else 0.0
        if alpha == 0.0 and a < MIN_LEN:   # parallel axes must not coincide
            a = float(rng.uniform(0.15, 0.45))
        if math.hypot(a, d) < MIN_LEN:
            d = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.1, 0.3))
        rows.append([a, alpha, d])
    reach = sum(abs(r[0]) + abs(r[2]) for r in rows)
    scale = float(rng.uniform(*REACH)) / reach
    return [(r[0] * scale, r[1], r[2] * scale) for r in rows]


def joint_origin(a, alpha, d):
    """Translation and rotation of the joint frame in its parent link's frame."""
    return np.array([a, -d * math.sin(alpha), d * math.cos(alpha)]), rot_x(alpha)


def box_frame(p, rng):
    """A rotation whose x axis lies along `p`, turned by a random angle about it."""
    x = p / np.linalg.norm(p)
    h = np.array([0.0, 0.0, 1.0]) if abs(x[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    y = np.cross(h, x)
    y /= np.linalg.norm(y)
    z = np.cross(x, y)
    r = np.column_stack([x, y, z])
    return r @ rot_x(float(rng.uniform(0, 2 * math.pi)))


def draw_inertials(kin, rng):
    """Per link (mass, com (3,), inertia about the COM (3, 3), box (length, width, height,
    rotation)) for the arm `kin`."""
    n = len(kin)
    out = []
    for i in range(n):
        p = (joint_origin(*kin[i + 1])[0] if i + 1 < n
             else np.array([0.0, 0.0, float(rng.uniform(*FLANGE))]))
        length = float(np.linalg.norm(p))
        taper = 1.0 - 0.5 * i / max(n - 1, 1)
        r = float(rng.uniform(*RADIUS)) * taper
        w, h = (float(v) * r for v in rng.uniform(1.2, 2.4, 2))
        lx = max(length, 2 * r)
        rot = box_frame(p, rng)
        mass = float(np.clip(rng.uniform(0.7, 1.3) * (2.0 + 20.0 * lx) * taper, *MASS))
        principal = mass / 12.0 * np.array([w * w + h * h, lx * lx + h * h, lx * lx + w * w])
        inertia = rot @ np.diag(principal) @ rot.T
        lateral = rot[:, 1:] @ rng.uniform(-0.5, 0.5, 2) * r
        com = float(rng.uniform(0.2, 0.8)) * p + lateral
        out.append({"mass": mass, "com": com, "inertia": inertia, "box": (lx, w, h, rot), "segment": p})
    return out


def check_inertials(links):
    """Raises ValueError unless every link has a positive mass, a symmetric positive-definite
    inertia whose principal moments satisfy the triangle inequalities, and its COM inside its
    box (the segment's box with the drawn width and height)."""
    for i, lk in enumerate(links, 1):
        if not lk["mass"] > 0:
            raise ValueError(f"link_{i}: mass {lk['mass']}")
        it = lk["inertia"]
        if not np.allclose(it, it.T, atol=1e-12):
            raise ValueError(f"link_{i}: inertia not symmetric")
        ev = np.linalg.eigvalsh(it)
        if ev.min() <= 0 or any(ev[k] > ev[(k + 1) % 3] + ev[(k + 2) % 3] for k in range(3)):
            raise ValueError(f"link_{i}: principal moments {ev} break the triangle inequalities")
        lx, w, h, rot = lk["box"]
        local = rot.T @ lk["com"]
        centre = rot.T @ (0.5 * lk["segment"])
        if np.any(np.abs(local - centre) > np.array([lx, w, h]) / 2 + 1e-12):
            raise ValueError(f"link_{i}: COM {lk['com']} outside its box")


def draw_arm(n, seed):
    """The arm of `n` joints drawn from `seed`: {'n', 'seed', 'kinematics', 'links'}."""
    rng = np.random.default_rng(seed)
    kin = draw_kinematics(n, rng)
    links = draw_inertials(kin, rng)
    check_inertials(links)
    return {"n": n, "seed": seed, "kinematics": kin, "links": links}


INERTIA_KEYS = {"ixx": (0, 0), "ixy": (0, 1), "ixz": (0, 2), "iyy": (1, 1), "iyz": (1, 2), "izz": (2, 2)}


def _f(x):
    return " ".join(repr(float(v)) for v in np.ravel(x))


def write_urdf(arm, path):
    """The arm as a URDF (rpy of the joints: (alpha, 0, 0); inertials in the link frame, rpy 0)."""
    root = ET.Element("robot", name=f"random_arm_{arm['seed']}")
    ET.SubElement(root, "link", name="base_link")
    parent = "base_link"
    for i, ((a, alpha, d), lk) in enumerate(zip(arm["kinematics"], arm["links"]), 1):
        link = ET.SubElement(root, "link", name=f"link_{i}")
        inert = ET.SubElement(link, "inertial")
        ET.SubElement(inert, "origin", xyz=_f(lk["com"]), rpy="0 0 0")
        ET.SubElement(inert, "mass", value=repr(float(lk["mass"])))
        it = lk["inertia"]
        ET.SubElement(inert, "inertia", **{k: repr(float(it[r, c])) for k, (r, c) in INERTIA_KEYS.items()})
        joint = ET.SubElement(root, "joint", name=f"joint_{i}", type="revolute")
        pos, _ = joint_origin(a, alpha, d)
        ET.SubElement(joint, "origin", xyz=_f(pos), rpy=_f([alpha, 0.0, 0.0]))
        ET.SubElement(joint, "parent", link=parent)
        ET.SubElement(joint, "child", link=f"link_{i}")
        ET.SubElement(joint, "axis", xyz="0 0 1")
        ET.SubElement(joint, "limit", lower=repr(-JOINT_LIMIT), upper=repr(JOINT_LIMIT), effort="1000",
                      velocity=repr(VEL_LIMIT))
        ET.SubElement(joint, "dynamics", damping="0.0", friction="0.0")
        parent = f"link_{i}"
    ET.indent(root)
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)


def write_mjcf(arm, path):
    """The arm as MJCF: nested bodies at the joint origins (quaternion of Rx(alpha)), hinge
    joints about z, explicit inertials (`fullinertia` about the COM, MuJoCo's order)."""
    root = ET.Element("mujoco", model=f"random_arm_{arm['seed']}")
    ET.SubElement(root, "compiler", angle="radian")
    ET.SubElement(root, "option", gravity="0 0 -9.81")
    parent = ET.SubElement(root, "worldbody")
    for i, ((a, alpha, d), lk) in enumerate(zip(arm["kinematics"], arm["links"]), 1):
        pos, _ = joint_origin(a, alpha, d)
        quat = [math.cos(alpha / 2), math.sin(alpha / 2), 0.0, 0.0]
        body = ET.SubElement(parent, "body", name=f"link_{i}", pos=_f(pos), quat=_f(quat))
        it = lk["inertia"]
        ET.SubElement(body, "inertial", pos=_f(lk["com"]), mass=repr(float(lk["mass"])),
                      fullinertia=_f([it[0, 0], it[1, 1], it[2, 2], it[0, 1], it[0, 2], it[1, 2]]))
        ET.SubElement(body, "joint", name=f"joint_{i}", type="hinge", axis="0 0 1")
        parent = body
    ET.indent(root)
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
