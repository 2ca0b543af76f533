#!/usr/bin/env python3
"""Writes meshes/hand.stl: the palm of urdf/arm7.urdf's gripper as a closed convex solid (ASCII STL,
millimetres: the URDF scales it by 0.001).

The palm is a hexagonal prism along y: its cross-section in the x-z plane is an 80 x 60 mm
rectangle centred on the origin whose two lower corners (towards the wrist, -z) are chamfered by
15 mm, extruded over y = -70 .. 70 mm. Faces are wound counter-clockwise seen from outside, so that
each facet normal points out of the solid. Run from anywhere; the file is rewritten in place."""
import os

# Cross-section (x, z) [mm], counter-clockwise seen from -y (x to the right, z up).
SECTION = [(-25.0, -30.0), (25.0, -30.0), (40.0, -15.0), (40.0, 30.0), (-40.0, 30.0), (-40.0, -15.0)]
HALF_WIDTH = 70.0  # y [mm]


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def unit(v):
    n = sum(x * x for x in v) ** 0.5
    return tuple(x / n for x in v)


def triangles():
    front = [(x, -HALF_WIDTH, z) for x, z in SECTION]  # y = -70 (cap seen from -y: CCW is outward)
    back = [(x, HALF_WIDTH, z) for x, z in SECTION]
    n = len(SECTION)
    tris = []
    for k in range(1, n - 1):  # fans over the two caps (convex hexagons)
        tris.append((front[0], front[k], front[k + 1]))
        tris.append((back[0], back[k + 1], back[k]))
    for k in range(n):  # the six sides, two triangles each
        a, b = front[k], front[(k + 1) % n]
        c, d = back[(k + 1) % n], back[k]
        tris.append((a, d, c))
        tris.append((a, c, b))
    return tris


def main():
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "meshes", "hand.stl")
    centre = (0.0, 0.0, sum(z for _, z in SECTION) / len(SECTION))
    lines = ["solid hand"]
    for t in triangles():
        normal = unit(cross(sub(t[1], t[0]), sub(t[2], t[0])))
        # Outward: the normal points away from a point inside the solid.
        assert sum(nk * (pk - ck) for nk, pk, ck in zip(normal, t[0], centre)) > 0.0
        lines.append("  facet normal %.6g %.6g %.6g" % normal)
        lines.append("    outer loop")
        for v in t:
            lines.append("      vertex %.6g %.6g %.6g" % v)
        lines.append("    endloop")
        lines.append("  endfacet")
    lines.append("endsolid hand")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
