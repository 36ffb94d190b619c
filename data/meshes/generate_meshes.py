#!/usr/bin/env python3
"""Writes the small meshes of data/meshes/ (see data/README.md). Deterministic: running it again
rewrites the same files byte for byte. Usage: python3 data/meshes/generate_meshes.py

Every triangle is counter-clockwise seen from its front side: +z for the flat meshes, outside for
the closed ones. Coordinates are written with Python's repr (shortest text that reads back to the
same double)."""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def fmt(x):
    x = float(x)
    if x == 0.0:
        return "0"  # also for -0.0
    if x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return repr(x)


def write_obj(name, header, points, triangles):
    with open(os.path.join(HERE, name), "w", newline="\n") as f:
        for line in header:
            f.write("# " + line + "\n")
        for p in points:
            f.write("v " + " ".join(fmt(c) for c in p) + "\n")
        for t in triangles:
            f.write("f " + " ".join(str(i + 1) for i in t) + "\n")


def write_off(name, header, points, triangles):
    with open(os.path.join(HERE, name), "w", newline="\n") as f:
        f.write("OFF\n")
        for line in header:
            f.write("# " + line + "\n")
        f.write(f"{len(points)} {len(triangles)} 0\n")
        for p in points:
            f.write(" ".join(fmt(c) for c in p) + "\n")
        for t in triangles:
            f.write("3 " + " ".join(str(i) for i in t) + "\n")


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def orient_outward(points, triangles):
    """Closed meshes around the origin: flip any triangle whose normal points inwards."""
    out = []
    for t in triangles:
        a, b, c = (points[i] for i in t)
        n = cross(sub(b, a), sub(c, a))
        centroid = [(a[i] + b[i] + c[i]) / 3 for i in range(3)]
        out.append(t if dot(n, centroid) > 0 else [t[0], t[2], t[1]])
    return out


def grid(nx, ny, width, height):
    """nx * ny vertices on [0,width]x[0,height], z = 0; vertex i + nx*j at (i, j). Alternating
    diagonals: cell (i, j) is split along (i,j)-(i+1,j+1) when i + j is even, along
    (i+1,j)-(i,j+1) when it is odd."""
    pts = [[width * i / (nx - 1), height * j / (ny - 1), 0.0] for j in range(ny) for i in range(nx)]
    tris = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            a, b = i + nx * j, i + 1 + nx * j
            c, d = i + 1 + nx * (j + 1), i + nx * (j + 1)
            if (i + j) % 2 == 0:
                tris += [[a, b, c], [a, c, d]]
            else:
                tris += [[a, b, d], [b, c, d]]
    return pts, tris


def icosphere(subdivisions):
    g = (1 + math.sqrt(5)) / 2
    pts = [[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0], [0, -1, g], [0, 1, g], [0, -1, -g],
           [0, 1, -g], [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]]
    tris = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
            [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
            [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]

    def unit(p):
        n = math.sqrt(dot(p, p))
        return [c / n for c in p]

    pts = [unit(p) for p in pts]
    for _ in range(subdivisions):
        cache = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                cache[key] = len(pts)
                pts.append(unit([(pts[a][i] + pts[b][i]) / 2 for i in range(3)]))
            return cache[key]

        new = []
        for a, b, c in tris:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        tris = new
    return pts, orient_outward(pts, tris)


# The organ of data/scenes/surgery_organ.json: an ellipsoid of semi-axes ORGAN_A (x and y) and
# ORGAN_C (z) about the origin, and the skin that lies on it, SKIN_GAP outside it.
ORGAN_A, ORGAN_C, SKIN_GAP = 0.085, 0.035, 0.0003


def organ():
    """The icosphere subdivided four times, scaled to the ellipsoid: its vertices lie on it, its
    facets within 0.02 mm inside it on the top."""
    pts, tris = icosphere(4)
    return [[ORGAN_A * p[0], ORGAN_A * p[1], ORGAN_C * p[2]] for p in pts], tris


def skin_height(x, y):
    """The skin's rest height over (x, y): the ellipsoid of semi-axes ORGAN_A + SKIN_GAP and
    ORGAN_C + SKIN_GAP, SKIN_GAP outside the organ along its normal on the top, a little less
    down its flanks (0.9 of it at the patch's corners)."""
    a, c = ORGAN_A + SKIN_GAP, ORGAN_C + SKIN_GAP
    return c * math.sqrt(1.0 - (x * x + y * y) / (a * a))


def organ_skin(n, width):
    """The grid of n x n vertices on [-width/2, width/2]^2 (alternating diagonals, as grid()),
    lifted onto skin_height."""
    pts, tris = grid(n, n, width, width)
    return [[p[0] - width / 2, p[1] - width / 2, skin_height(p[0] - width / 2, p[1] - width / 2)]
            for p in pts], tris


def main():
    note = "generated by data/meshes/generate_meshes.py for cutsim (GPL-3.0-or-later)"

    pts, tris = grid(10, 10, 1.0, 1.0)
    write_obj("grid_10x10.obj",
              ["Flat 10x10-vertex grid on [0,1]^2 (z = 0), 9x9 cells, alternating diagonals:",
               "cell (i,j) is cut along (i,j)-(i+1,j+1) if i+j is even, else (i+1,j)-(i,j+1).",
               "Vertex i + 10*j is at (i/9, j/9, 0). Triangles counter-clockwise seen from +z.",
               "100 vertices, 261 edges, 162 triangles, 36 boundary edges, 1 component.", note],
              pts, tris)

    # The single hinge of spec/bending-springs.md: edge CD with wings A and B.
    C, D, A, B = [0, 0, 0], [1, 0, 0], [0.3, -1, 0], [0.6, 2, 0]
    write_obj("hinge.obj",
              ["One hinge: two triangles on the edge C-D, wing A below it, wing B above it.",
               "Vertices 1..4 are C=(0,0,0), D=(1,0,0), A=(0.3,-1,0), B=(0.6,2,0).",
               "Triangles (C,A,D) and (C,D,B), counter-clockwise seen from +z.",
               "4 vertices, 5 edges, 2 triangles, 4 boundary edges, 1 component.", note],
              [C, D, A, B], [[0, 2, 1], [0, 1, 3]])

    pts = [[i, j, 0] for j in range(2) for i in range(6)]
    tris = []
    for i in range(5):
        a, b, c, d = i, i + 1, i + 7, i + 6
        tris += [[a, b, c], [a, c, d]]
    write_off("strip.off",
              ["A strip of 5 unit squares along x, 2x6 vertices, z = 0, each square cut along",
               "its (i,0)-(i+1,1) diagonal. Vertex i + 6*j is at (i, j, 0).",
               "12 vertices, 21 edges, 10 triangles, 12 boundary edges, 1 component.", note],
              pts, tris)

    pts = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
    tris = [[i, j, k] for i in (0, 1) for j in (2, 3) for k in (4, 5)]
    write_off("octahedron.off",
              ["Regular octahedron with vertices at +-x, +-y, +-z (unit distance), closed,",
               "triangles counter-clockwise seen from outside.",
               "6 vertices, 12 edges, 8 triangles, 0 boundary edges, 1 component.", note],
              pts, orient_outward(pts, tris))

    pts, tris = icosphere(1)
    write_off("icosphere_1.off",
              ["Unit icosphere: icosahedron subdivided once (each triangle into four), vertices",
               "projected on the unit sphere; closed, counter-clockwise seen from outside.",
               "42 vertices, 120 edges, 80 triangles, 0 boundary edges, 1 component.", note],
              pts, tris)

    pts = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [3, 0, 0], [3, 1, 0], [2, 1, 0]]
    tris = [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]]
    write_obj("two_components.obj",
              ["Two unit squares in z = 0 that do not touch: [0,1]x[0,1] and [2,3]x[0,1], each",
               "cut along its (x0,0)-(x0+1,1) diagonal; counter-clockwise seen from +z.",
               "8 vertices, 10 edges, 4 triangles, 8 boundary edges, 2 components.", note],
              pts, tris)

    pts, tris = organ()
    write_obj("organ.obj",
              ["A rounded organ: an ellipsoid of semi-axes 8.5 cm (x, y) and 3.5 cm (z) about the",
               "origin (the unit icosphere subdivided four times, scaled); closed, counter-",
               "clockwise seen from outside. The obstacle of data/scenes/surgery_organ.json.",
               "2562 vertices, 7680 edges, 5120 triangles, 0 boundary edges, 1 component.", note],
              pts, tris)

    pts, tris = organ_skin(31, 0.1)
    write_obj("organ_skin.obj",
              ["A 10 cm x 10 cm patch of skin lying on organ.obj: the grid of 31 x 31 vertices on",
               "[-0.05, 0.05]^2 (alternating diagonals, as grid_10x10.obj), vertex i + 31*j over",
               "(-0.05 + i/300, -0.05 + j/300), lifted onto the ellipsoid of semi-axes 8.53 cm and",
               "3.53 cm (0.3 mm outside the organ on its top). Counter-clockwise seen from above.",
               "961 vertices, 2760 edges, 1800 triangles, 120 boundary edges, 1 component.", note],
              pts, tris)


if __name__ == "__main__":
    main()
