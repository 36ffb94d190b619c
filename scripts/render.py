#!/usr/bin/python3
"""Pictures of a cutsim run without ParaView: frames of the surface and plots of its CSV series.

    /usr/bin/python3 scripts/render.py RUN_DIR [--frames 0,0.4,0.7,1] [--out PREFIX] [--view ELEV,AZIM]

RUN_DIR is what `cutsim run` wrote (surface_NNNNNN.vtp, surface.pvd, steps.csv). Writes
PREFIX_frames.png (the surface at the given fractions of the run, triangles coloured by strain,
cut lips and borders drawn as lines) and PREFIX_series.png (energies, solver iterations and
residuals with flagged steps marked, counts, grasp forces), PREFIX defaulting to RUN_DIR/render,
and prints what a user would check: the smallest triangle angle of the last frame, its largest
strain, the flagged steps. Needs Debian's python3-matplotlib and python3-numpy.
"""
import argparse
import csv
import math
import os
import re
import sys
import xml.etree.ElementTree as ET

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection  # noqa: E402


def read_vtp(path):
    root = ET.parse(path).getroot()
    arrays = {}
    for da in root.iter("DataArray"):
        values = np.array(da.text.split(), dtype=float) if da.text else np.zeros(0)
        n = int(da.get("NumberOfComponents", "1"))
        arrays[da.get("Name")] = values.reshape(-1, n) if n > 1 else values
    points = arrays["position"] if "position" in arrays else arrays.get("Points")
    conn = arrays["connectivity"].astype(int)
    offsets = arrays["offsets"].astype(int)
    tris = conn.reshape(-1, 3) if len(offsets) * 3 == len(conn) else None
    return points, tris, arrays


def frames_of(run):
    pvd = os.path.join(run, "surface.pvd")
    if not os.path.exists(pvd):
        pvd = os.path.join(run, "surface.partial.pvd")
    root = ET.parse(pvd).getroot()
    return [(float(d.get("timestep")), os.path.join(run, d.get("file"))) for d in root.iter("DataSet")]


def boundary_edges(tris):
    count = {}
    for t in tris:
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            k = (min(a, b), max(a, b))
            count[k] = count.get(k, 0) + 1
    return [k for k, c in count.items() if c == 1]


def min_angle_deg(points, tris):
    worst = 180.0
    for t in tris:
        p = points[t]
        for i in range(3):
            u, v = p[(i + 1) % 3] - p[i], p[(i + 2) % 3] - p[i]
            nu, nv = np.linalg.norm(u), np.linalg.norm(v)
            if nu > 0 and nv > 0:
                worst = min(worst, math.degrees(math.acos(max(-1.0, min(1.0, u.dot(v) / (nu * nv))))))
    return worst


def obstacle_polys(obstacles, lo, hi):
    """The obstacles' triangles; planes (an obstacle of two triangles) cut down to the surface's extent."""
    if obstacles is None:
        return np.zeros((0, 3, 3))
    pts, tris, arrays = obstacles
    owner = arrays["obstacle"].astype(int)
    polys = []
    for k in np.unique(owner):
        t = tris[owner == k]
        p = pts[t]
        if len(t) == 2:  # a plane: shrink its square around the surface's centre
            c = p.reshape(-1, 3).mean(axis=0)
            half = 0.75 * max(hi - lo)
            d = p - c
            scale = half / max(np.abs(d).max(), 1e-12)
            mid = (lo + hi) / 2
            n = np.cross(p[0][1] - p[0][0], p[0][2] - p[0][0])
            n /= np.linalg.norm(n) or 1.0
            shift = (mid - c) - n * np.dot(mid - c, n)
            p = c + shift + d * scale
        polys.extend(p)
    return np.array(polys)


def draw_frame(ax, points, tris, strain, vmax, title, view, obstacles=None):
    polys = points[tris]
    cmap = plt.get_cmap("viridis")
    colors = cmap(np.clip(strain / vmax if vmax > 0 else strain * 0, 0, 1))
    lo, hi = points.min(axis=0), points.max(axis=0)
    obs = obstacle_polys(obstacles, lo, hi)
    surface_lo, surface_hi = lo, hi
    if len(obs):
        # One collection, so that the surface and the obstacles are depth-sorted together.
        polys = np.concatenate([polys, obs])
        colors = np.concatenate([colors, np.tile([0.72, 0.72, 0.76, 0.55], (len(obs), 1))])
        lo, hi = np.minimum(lo, obs.reshape(-1, 3).min(axis=0)), np.maximum(hi, obs.reshape(-1, 3).max(axis=0))
    edgecolors = [(0, 0, 0, 0.15)] * len(tris) + [(0.3, 0.3, 0.3, 0.08)] * len(obs)
    coll = Poly3DCollection(polys, facecolors=colors, edgecolors=edgecolors, linewidths=0.2)
    ax.add_collection3d(coll)
    edges = boundary_edges(tris)
    ax.add_collection3d(Line3DCollection([points[list(e)] for e in edges], colors="crimson", linewidths=0.8))
    centre, half = (lo + hi) / 2, max(hi - lo) / 2 or 1.0
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        setter(c - half, c + half)
    ax.view_init(*view)
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")


def obstacle_frames(run):
    for name in ("obstacles.pvd", "obstacles.partial.pvd"):
        pvd = os.path.join(run, name)
        if os.path.exists(pvd):
            return {float(d.get("timestep")): os.path.join(run, d.get("file")) for d in ET.parse(pvd).getroot().iter("DataSet")}
    return {}


def render_frames(run, fractions, out, view):
    frames = frames_of(run)
    obstacles = obstacle_frames(run)
    chosen = sorted({min(len(frames) - 1, int(round(f * (len(frames) - 1)))) for f in fractions})
    data = [(frames[i][0],) + read_vtp(frames[i][1]) for i in chosen]
    vmax = max(float(np.percentile(a["strain"], 99)) for _, _, _, a in data if len(a["strain"])) or 1e-6
    fig = plt.figure(figsize=(5.2 * len(data), 5.2))
    for k, (t, pts, tris, arrays) in enumerate(data):
        ax = fig.add_subplot(1, len(data), k + 1, projection="3d")
        obs = read_vtp(obstacles[t]) if t in obstacles else None
        draw_frame(ax, pts, tris, arrays["strain"], vmax, f"t = {t:g} s, {len(tris)} triangles", view, obs)
    sm = plt.cm.ScalarMappable(cmap="viridis", norm=plt.Normalize(0, vmax))
    fig.colorbar(sm, ax=fig.axes, shrink=0.6, label="strain (largest principal Green strain)")
    fig.suptitle(os.path.basename(os.path.normpath(run)) + ": surface coloured by strain, borders and cut lips in red")
    fig.savefig(out, dpi=110)
    plt.close(fig)
    t, pts, tris, arrays = data[-1]
    return min_angle_deg(pts, tris), float(arrays["strain"].max()) if len(arrays["strain"]) else 0.0


def render_series(run, out):
    rows = list(csv.DictReader(open(os.path.join(run, "steps.csv"))))
    if not rows:
        return []
    col = lambda k: np.array([float(r[k]) for r in rows])  # noqa: E731
    t = col("time")
    contact = "contact_active" in rows[0]
    fig, axes = plt.subplots(3 if contact else 2, 2, figsize=(12, 11 if contact else 7.5))
    ax = axes[0][0]
    for k in rows[0]:
        if k == "kinetic_energy" or k.startswith("potential_"):
            ax.plot(t, col(k), label=k)
    ax.set_yscale("symlog", linthresh=1e-9)
    ax.set_title("energies (J)")
    ax.legend(fontsize=7)
    ax = axes[0][1]
    ax.plot(t, col("solver_iterations"), label="linear iterations", color="tab:blue")
    if "newton_iterations" in rows[0]:
        ax.plot(t, col("newton_iterations"), label="Newton iterations", color="tab:green")
    ax.set_title("solver work per step")
    ax.legend(fontsize=7)
    ax2 = ax.twinx()
    res = np.maximum(col("solver_residual"), 1e-18)
    ax2.semilogy(t, res, color="tab:orange", lw=0.8, label="relative residual")
    flagged = [i for i, r in enumerate(rows) if r.get("solver_flags", "ok") != "ok"]
    if flagged:
        ax2.scatter(t[flagged], res[flagged], color="red", s=10, zorder=5, label="flagged step")
    ax2.legend(fontsize=7, loc="lower right")
    ax = axes[1][0]
    for k in ("points", "triangles"):
        ax.plot(t, col(k), label=k)
    ax.set_title("mesh counts")
    ax.legend(fontsize=7)
    ax = axes[1][1]
    grasp = [k for k in rows[0] if re.search(r"_f[xyz]$", k)]
    for k in grasp:
        ax.plot(t, col(k), label=k)
    ax.set_title("grasp reaction forces (N)" if grasp else "no grasp")
    if grasp:
        ax.legend(fontsize=7)
    if contact:
        ax = axes[2][0]
        for k in rows[0]:
            if k.endswith("_normal_force") or k.endswith("_friction_force"):
                ax.plot(t, col(k), label=k, ls="-" if k.endswith("_normal_force") else "--")
        ax.set_title("contact forces (sums of magnitudes, N)")
        ax.legend(fontsize=7)
        ax = axes[2][1]
        for k in ("contact_active", "contact_excluded", "contact_clamped", "contact_splits"):
            ax.plot(t, col(k), label=k)
        ax.set_yscale("symlog", linthresh=1)
        ax.set_title("contact pairs, clamped points, split steps")
        ax.legend(fontsize=7)
    for a in axes.flat:
        a.set_xlabel("t (s)")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return flagged


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run")
    ap.add_argument("--frames", default="0,0.35,0.7,1")
    ap.add_argument("--out")
    ap.add_argument("--view", default="35,-60")
    a = ap.parse_args()
    prefix = a.out or os.path.join(a.run, "render")
    view = tuple(float(v) for v in a.view.split(","))
    angle, strain = render_frames(a.run, [float(f) for f in a.frames.split(",")], prefix + "_frames.png", view)
    flagged = render_series(a.run, prefix + "_series.png")
    print(f"wrote {prefix}_frames.png and {prefix}_series.png")
    print(f"last frame: smallest triangle angle {angle:.2f} degrees (current positions), largest strain {strain:.4g}")
    print(f"flagged steps: {len(flagged)}")


if __name__ == "__main__":
    sys.exit(main())
