#!/usr/bin/env python3
"""Writes data/scenes/surgery_organ.json: skin over a rounded organ, incised along a curve by a
scalpel, the flap taken by forceps and laid back, the wound closed by a running suture and sewn.

Every instrument's path is computed here from the skin's rest surface (the ellipsoid of
data/meshes/generate_meshes.py), so that the blade follows the curved skin at a constant depth and
the needles pierce it where the lips are. Deterministic: running it again rewrites the same file
byte for byte. Usage: /usr/bin/python3 scripts/make_surgery_organ.py"""
import json
import math
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "data", "meshes"))
import generate_meshes as gm  # noqa: E402  (the organ's and the skin's shapes)

OUT = os.path.join(ROOT, "data", "scenes", "surgery_organ.json")

RADIUS = 0.02                  # the incision: an arc of this radius about the top of the organ
ARC = (130.0, 410.0)           # from 130 degrees round through 270 (-y) to 50: the base at +y
BLADE_UNDER = 0.0015           # the blade's tip under the skin (the skin is 0.3 mm over the organ)
BLADE = 0.005                  # the blade's length
STITCH_ANGLES = [140.0 + 20.0 * k for k in range(13)]
BITE_OUT = 0.004               # a stitch's entry and exit from the incision, either side


def r6(x):
    return round(x, 6) + 0.0


def skin_point(x, y):
    return [x, y, gm.skin_height(x, y)]


def skin_normal(p):
    a, c = gm.ORGAN_A + gm.SKIN_GAP, gm.ORGAN_C + gm.SKIN_GAP
    n = [p[0] / (a * a), p[1] / (a * a), p[2] / (c * c)]
    length = math.sqrt(sum(v * v for v in n))
    return [v / length for v in n]


def on_arc(theta_deg, radius=RADIUS):
    t = math.radians(theta_deg)
    return skin_point(radius * math.cos(t), radius * math.sin(t))


def scalpel_path(duration):
    """A keyframe every 10 degrees: the tip BLADE_UNDER under the skin along its normal, the blade
    along the normal (pointing out of the organ)."""
    rows = []
    steps = int(round((ARC[1] - ARC[0]) / 10.0))
    for k in range(steps + 1):
        theta = ARC[0] + 10.0 * k
        p = on_arc(theta)
        n = skin_normal(p)
        tip = [p[i] - BLADE_UNDER * n[i] for i in range(3)]
        rows.append([r6(duration * k / steps)] + [r6(v) for v in tip] + [r6(v) for v in n])
    return rows


def forceps_path():
    """The jaws close on the flap's tip, 5 mm inside the incision at -y, their tips 4 mm under the
    skin and their axis along its normal there (+z), then turn over the flap's base (the chord
    across the arc's gap) by up to 100 degrees, the flap with them, hold it open, lay it back the
    same way, and open. Rows [t, x, y, z, ax, ay, az, opening]: the jaws turn as the flap does."""
    tip = on_arc(270.0, RADIUS - 0.005)
    base = on_arc(90.0, RADIUS * math.sin(math.radians(ARC[1] - 360.0)))
    drop = 0.004
    closed, opened = 0.006, 0.015
    arm = [tip[1] - base[1], tip[2] - drop - base[2]]  # from the base to the jaws' tip (y, z)

    def at(phi_deg):
        # a turn by -phi about the x axis (the tip at -y rises over the base at +y)
        phi = math.radians(phi_deg)
        c, s = math.cos(phi), math.sin(phi)
        y = base[1] + c * arm[0] + s * arm[1]
        z = base[2] - s * arm[0] + c * arm[1]
        return [0.0, y, z, 0.0, s, c]

    rows = [[0.0] + at(0) + [opened], [0.1] + at(0) + [closed]]
    up = [(0.3, 30), (0.5, 60), (0.7, 85), (0.9, 100)]
    down = [(1.4, 100), (1.6, 85), (1.8, 60), (2.0, 30), (2.2, 0)]
    rows += [[t] + at(phi) + [closed] for t, phi in up + down]
    rows.append([2.3] + at(0) + [opened])
    return [[r6(v) for v in row] for row in rows]


def stitches():
    out = []
    for theta in STITCH_ANGLES:
        a = on_arc(theta, RADIUS + BITE_OUT)
        b = on_arc(theta, RADIUS - BITE_OUT)
        out.append([r6(v) for v in a + b])
    return out


def arc_polyline():
    return [[r6(v) for v in on_arc(ARC[0] - 5.0 + 10.0 * k)]
            for k in range(int((ARC[1] - ARC[0]) / 10.0) + 2)]


def border(axis, value, low):
    lo, hi = [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]
    if low:
        hi[axis] = value
    else:
        lo[axis] = value
    return {"type": "fixed", "box": [lo, hi]}


DESCRIPTION = (
    "Skin over a rounded organ, every instrument in world coordinates (docs/instruments.md). "
    "A 10 cm x 10 cm patch of skin (31 x 31 vertices, 20 g, corotational FEM membrane under 3% "
    "resting tension with dihedral bending, border held), curved at rest, lies 0.3 mm over an "
    "organ (a mesh obstacle: an ellipsoid of semi-axes 8.5, 8.5 and 3.5 cm, "
    "data/meshes/organ.obj), attached to it (an Attachment), with frictionless contact against "
    "the organ and itself (0.5 mm thick). From t = 0.2 s to 1.2 s a scalpel (a 5 mm blade, its "
    "tip 1.5 mm under the skin, along the skin's normal) follows a 280-degree arc of 2 cm radius "
    "over the top of the organ: a curved incision on a curved rest surface, repaired to 20 "
    "degrees as it goes; at t = 1.25 s the flap inside it and a 2 mm margin are undermined "
    "(dissect). From t = 1.3 s forceps take the flap's tip and, turning with it, turn the flap over "
    "its base by 100 degrees, showing the organ beneath, hold it, lay it back by t = 3.5 s and "
    "open. At t = "
    "3.7 s a running suture of thirteen stitches 7 mm apart, each 4 mm either side of the "
    "incision, tightens to 1.5 mm over 0.8 s, and at t = 4.7 s the wound is sewn (tolerance "
    "1.5 mm, along the incision). What to see: the incision follows the curved skin; the flap "
    "turns up and back down onto the organ (the contact keeps it out of the organ), the wound "
    "gapes under the skin's tension (about 3 mm), the lips come together as the threads shorten "
    "(drawn in green in the player), the skin puckering beside each stitch, and become one "
    "surface again where they lie within the tolerance (more than half of the incision; the "
    "stretches whose lips stay further apart are left open), and the skin settles on the organ "
    "till t = 5.2 s. Made by scripts/make_surgery_organ.py.")


def scene():
    return {
        "description": DESCRIPTION,
        "mesh": {"file": "../meshes/organ_skin.obj"},
        "mass": {"total": 0.02},
        "gravity": [0, 0, -9.81],
        "contact": {"thickness": 0.0005, "stiffness": 15},
        "obstacles": [{"type": "mesh", "name": "organ", "file": "../meshes/organ.obj"}],
        "forceFields": [
            {"type": "TriangularFEM", "label": "membrane", "youngModulus": 1000000.0,
             "poissonRatio": 0.45, "thickness": 0.002, "restScale": 0.97},
            {"type": "DihedralBending", "label": "bending", "bendingStiffness": 0.0002},
            {"type": "Attachment", "label": "tissue", "stiffness": 200000.0, "damping": 200},
            {"type": "Sutures", "label": "sutures", "stiffness": 600, "damping": 0.5},
        ],
        "constraints": [border(0, -0.0499, True), border(0, 0.0499, False),
                        border(1, -0.0499, True), border(1, 0.0499, False)],
        "integrator": {"type": "implicit-euler", "rayleighMass": 2.0},
        "linearSolver": {"type": "cholmod"},
        "timeStep": 0.005,
        "duration": 5.2,
        "output": {"every": 10},
        "timeline": [
            {"from": 0.2, "to": 1.2, "action": "scalpel", "depth": BLADE,
             "path": scalpel_path(1.0)},
            {"at": 1.25, "action": "dissect",
             "sphere": {"center": [r6(v) for v in skin_point(0.0, 0.0)], "radius": RADIUS + 0.002}},
            {"from": 1.3, "to": 3.6, "action": "forceps", "name": "forceps",
             "across": [1, 0, 0], "radius": 0.003, "length": 0.01, "path": forceps_path()},
            {"at": 3.7, "action": "suture", "bite": 0.003, "stitches": stitches(),
             "length": 0.0015, "tighten": 0.8},
            {"at": 4.7, "action": "sew", "tolerance": 0.0015, "near": arc_polyline(),
             "radius": 0.004},
        ],
    }


def main():
    text = json.dumps(scene(), indent=2)
    # Lists of numbers on one line each (a keyframe, a point), as the other scenes write them.
    text = re.sub(r"\[[-0-9.e,\s]+\]", lambda m: " ".join(m.group(0).split()).replace("[ ", "[").replace(" ]", "]"), text)
    with open(OUT, "w", newline="\n") as f:
        f.write(text + "\n")
    print("wrote", os.path.relpath(OUT, ROOT))


if __name__ == "__main__":
    main()
