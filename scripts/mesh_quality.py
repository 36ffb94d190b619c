#!/usr/bin/python3
"""Triangle quality of OBJ meshes (a run's final_rest.obj, say): smallest angle, mean of the
triangles' smallest angles, largest angle, how many triangles have a smallest angle under 10 and
20 degrees, the shortest edge and the smallest altitude (which bounds a stable explicit time step)
relative to the median edge. Usage: scripts/mesh_quality.py MESH.obj [MESH.obj ...]"""
import sys

import numpy as np


def read_obj(path):
    points, tris = [], []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "v":
                points.append([float(x) for x in parts[1:4]])
            elif parts[0] == "f":
                tris.append([int(x.split("/")[0]) - 1 for x in parts[1:4]])
    return np.array(points), np.array(tris, dtype=int)


def angles(points, tris):
    p = points[tris]  # (n, 3, 3)
    out = []
    for k in range(3):
        a, b, c = p[:, k], p[:, (k + 1) % 3], p[:, (k + 2) % 3]
        u, v = b - a, c - a
        cross = np.linalg.norm(np.cross(u, v), axis=1)
        out.append(np.degrees(np.arctan2(cross, np.einsum("ij,ij->i", u, v))))
    return np.stack(out, axis=1)


def main():
    if len(sys.argv) < 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    for path in sys.argv[1:]:
        try:
            points, tris = read_obj(path)
        except (OSError, ValueError) as e:
            print(f"{path}: {e}", file=sys.stderr)
            return 2
        if len(tris) == 0:
            print(f"{path}: no triangles", file=sys.stderr)
            return 2
        a = angles(points, tris)
        mn = a.min(axis=1)
        p = points[tris]
        lengths = np.stack([np.linalg.norm(p[:, (k + 1) % 3] - p[:, k], axis=1) for k in range(3)], axis=1)
        area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
        height = 2 * area / lengths.max(axis=1)  # smallest altitude: what limits an explicit step
        median = np.median(lengths)
        print(f"{path}: {len(tris)} triangles, smallest angle {mn.min():.2f} deg, mean smallest "
              f"{mn.mean():.2f} deg, largest {a.max():.1f} deg, under 10 deg: {(mn < 10).sum()}, "
              f"under 20 deg: {(mn < 20).sum()}, shortest edge {100 * lengths.min() / median:.1f}% and "
              f"smallest altitude {100 * height.min() / median:.1f}% of the median edge")
    return 0


if __name__ == "__main__":
    sys.exit(main())
