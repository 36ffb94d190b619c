#!/usr/bin/python3
"""A tearing study: the notched sheet of data/scenes/tearing.json pulled apart, run once per value
of a parameter of its fracture (the critical strain, by default), measuring when the crack starts,
how it grows, when the sheet parts and the largest pulling force.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/tearing_study.py
        [--parameter criticalStrain|length|speed|timeStep] [--values 0.06,0.08,...] [--out DIR] [--quick]
    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/tearing_study.py --paths [--out DIR] [--quick]

Writes DIR/tearing_study.png (crack length and pulling force over time for each value; crack
start and parting time against the value) and DIR/tearing_study.csv (one row per value); DIR
defaults to out/tearing_study.

With --paths, the same sheet is run instead in five ways that must tear alike (the scene as it
is; a time step 4 times smaller; the other diagonal pattern; a mesh twice as fine; explicit
stepping at a time step 500 times smaller, under its stability limit through the parting) and the crack paths are drawn in the rest plane:
DIR/tearing_paths.png (each run's cut lips, and their distance from the notch axis along the
crack) and DIR/tearing_paths.csv (one row per run: crack start, parting time, crack depth, the
path's largest distance from the notch axis in metres and in cells, and its largest distance from
the first run's path, band by band 5 cm deep, in the first run's cells).
"""
import argparse
import csv
import json
import pathlib
import sys

import numpy as np

import cutsim

ROOT = pathlib.Path(__file__).resolve().parents[2]
DEFAULTS = {"criticalStrain": "0.06,0.08,0.1,0.12,0.14", "length": "0.06,0.1,0.14",
            "speed": "0.5,1,2", "timeStep": "0.0025,0.005,0.01"}


def boundary_length(rest, triangles):
    """Total rest length of the edges that belong to one triangle only."""
    e = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    unique, count = np.unique(e, axis=0, return_counts=True)
    b = unique[count == 1]
    return float(np.linalg.norm(rest[b[:, 0]] - rest[b[:, 1]], axis=1).sum())


def pieces(num_slots, triangles):
    """Number of connected pieces of the surface (union-find over the triangles' points)."""
    parent = np.arange(num_slots)

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b, c in triangles:
        ra, rb, rc = find(a), find(b), find(c)
        parent[rb] = ra
        parent[find(rc)] = ra
    return len({find(p) for p in np.unique(triangles)})


def simulate(scene):
    """Runs the scene to its end, every 0.01 s recording the time, the crack's length (m), the
    right grasp's pulling force (N) and the number of pieces; returns the simulation and the
    series (an array, a row per record)."""
    sim = cutsim.Simulation(scene)
    sim.step(1)  # the notch is cut at t = 0
    initial = boundary_length(sim.rest, sim.triangles())
    series = []
    every = max(1, int(round(0.01 / sim.time_step)))
    while not sim.finished:
        sim.step(every)
        tri = sim.triangles()
        crack = (boundary_length(sim.rest, tri) - initial) / 2  # two lips per length of crack
        force = float(np.linalg.norm(sim.grasp_forces().get("right", np.zeros(3))))
        series.append((sim.time, crack, force, pieces(sim.num_slots, tri)))
    return sim, np.array(series)


def first_time(series, column, above):
    """The first recorded time at which the column exceeds `above` (NaN if never)."""
    t = series[series[:, column] > above, 0]
    return float(t[0]) if t.size else float("nan")


def run_one(base, parameter, value, quick):
    scene = json.loads(json.dumps(base))
    fracture = next(a for a in scene["timeline"] if a["action"] == "fracture")
    if parameter == "timeStep":
        scene["timeStep"] = value
    else:
        fracture[parameter] = value
    if quick:
        scene["mesh"]["grid"].update(nx=20, ny=20)
        scene["duration"] = 1.4
    sim, s = simulate(scene)
    return {
        "value": value,
        "crack_start": first_time(s, 1, 0.01),
        "parted_at": first_time(s, 3, 1.5),
        "crack_length": float(s[-1, 1]),
        "peak_force": float(s[:, 2].max()),
        "flagged_steps": sim.solve_summary["flagged_steps"],
        "series": s,
    }


# The runs of --paths: (label, changes to the scene).
PATH_RUNS = [
    ("as the scene is", {}),
    ("time step / 4", {"timeStep": 0.00125}),
    ("one-way diagonals", {"diagonals": "oneway"}),
    ("mesh h / 2 (51 x 51)", {"n": 51}),
    ("explicit, time step / 500", {"timeStep": 1e-5, "explicit": True}),
]


def crack_lips(rest, triangles):
    """The rest-plane segments of the border that are not the sheet's outer border: the notch and
    the crack (both lips, which coincide in the rest plane)."""
    e = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    unique, count = np.unique(e, axis=0, return_counts=True)
    b = unique[count == 1]
    a, c = rest[b[:, 0], :2], rest[b[:, 1], :2]
    eps = 1e-9
    outer = np.zeros(len(b), dtype=bool)
    for k in (0, 1):  # both ends on one side of the unit square
        for v in (0.0, 1.0):
            outer |= (np.abs(a[:, k] - v) < eps) & (np.abs(c[:, k] - v) < eps)
    return a[~outer], c[~outer]


def run_path(base, label, change, quick):
    scene = json.loads(json.dumps(base))
    if "timeStep" in change:
        scene["timeStep"] = change["timeStep"]
    if "diagonals" in change:
        scene["mesh"]["grid"]["diagonals"] = change["diagonals"]
    n = change.get("n", scene["mesh"]["grid"]["nx"])
    if quick:
        scene["duration"] = 0.7  # the crack's first 0.3 s
    scene["mesh"]["grid"].update(nx=n, ny=n)
    if change.get("explicit"):
        scene["integrator"] = {"type": "explicit-euler"}
        scene.pop("linearSolver", None)
    notch = next(a for a in scene["timeline"] if a["action"] == "cut")["polyline"]
    notch_x, notch_y = notch[-1][0], notch[-1][1]
    sim, series = simulate(scene)
    if not np.all(np.isfinite(sim.x[np.unique(sim.triangles())])):
        raise SystemExit(f"{label}: positions are not finite at t = {sim.time}")
    start, parted = first_time(series, 1, 0.01), first_time(series, 3, 1.5)
    a, c = crack_lips(sim.rest, sim.triangles())
    below = (np.minimum(a[:, 1], c[:, 1]) < notch_y - 1e-9)
    dev = np.abs(np.concatenate([a[below, 0], c[below, 0]]) - notch_x)
    cell = 1.0 / (n - 1)
    # The crack's segments by their midpoints (both lips coincide in the rest plane, once each),
    # and the path by bands 5 cm deep below the notch tip: the mean x of those midpoints.
    mid = np.unique(np.round(0.5 * (a[below] + c[below]), 9), axis=0)
    bands = {}
    for x, y in mid[:, :2]:
        bands.setdefault(int((notch_y - y) / 0.05), []).append(x)
    r = {"label": label, "crack_start": start, "parted_at": parted,
         "largest_offset_m": float(dev.max()) if dev.size else float("nan"), "cell": cell,
         "crack_depth_m": float(notch_y - np.minimum(a[below, 1], c[below, 1]).min()) if below.any() else 0.0,
         "bands": {b: float(np.mean(xs)) for b, xs in bands.items()},
         "lips": (a, c), "mid": mid, "notch": (notch_x, notch_y), "flagged_steps": sim.solve_summary["flagged_steps"]}
    r["largest_offset_cells"] = r["largest_offset_m"] / cell
    return r


def paths(args):
    base = json.loads((ROOT / "data/scenes/tearing.json").read_text())
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    results = []
    for i, (label, change) in enumerate(PATH_RUNS):
        r = run_path(base, label, change, args.quick)
        results.append(r)
        print(f"[{i + 1}/{len(PATH_RUNS)}] {label}: crack starts at t = {r['crack_start']:.3f} s, sheet parted at "
              f"t = {r['parted_at']:.3f} s, path at most {r['largest_offset_m'] * 1000:.1f} mm "
              f"({r['largest_offset_cells']:.2f} cells) off the notch axis, crack {r['crack_depth_m']:.3f} m deep",
              file=sys.stderr)
    # Each path against the first run's, band by band (in the first run's cells).
    first = results[0]
    for r in results:
        common = sorted(set(r["bands"]) & set(first["bands"]))
        gaps = [abs(r["bands"][b] - first["bands"][b]) for b in common]
        r["gap_to_first_cells"] = max(gaps) / first["cell"] if gaps else float("nan")
        r["bands_compared"] = len(common)
    with open(out / "tearing_paths.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run", "crack_start_s", "parted_at_s", "crack_depth_m", "largest_offset_m", "largest_offset_cells",
                    "gap_to_first_cells", "bands_compared", "flagged_steps"])
        for r in results:
            w.writerow([r["label"], r["crack_start"], r["parted_at"], r["crack_depth_m"], r["largest_offset_m"],
                        r["largest_offset_cells"], r["gap_to_first_cells"], r["bands_compared"], r["flagged_steps"]])

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    fig, axes = plt.subplots(1, len(results) + 1, figsize=(3.2 * (len(results) + 1), 3.6))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, r, col in zip(axes, results, colours):
        a, c = r["lips"]
        nx, ny = r["notch"]
        ax.add_collection(LineCollection(np.stack([a, c], axis=1), colors=col, linewidths=1.5))
        ax.plot([nx, nx], [0, 1], "k:", lw=0.7)
        ax.plot([0, 1, 1, 0, 0], [0, 0, 1, 1, 0], "k-", lw=0.8)
        ax.set(xlim=(-0.02, 1.02), ylim=(-0.02, 1.02), aspect="equal", xticks=[], yticks=[])
        ax.set_title(f"{r['label']}\nstarts {r['crack_start']:.2f} s, parts {r['parted_at']:.2f} s", fontsize=9)
        for side in ax.spines.values():
            side.set_visible(False)
        # The overlay: the crack's segments by their midpoints, top to bottom.
        ys, xs = r["mid"][:, 1], r["mid"][:, 0] - nx
        order = np.argsort(-ys)
        axes[-1].plot(1000 * xs[order], ys[order], ".-", color=col, ms=2, lw=0.8, label=r["label"])
    cell = results[0]["cell"]
    axes[-1].axvspan(-500 * cell, 500 * cell, color="0.9", zorder=0, label="half a cell either side")
    axes[-1].set(xlabel="offset from the notch axis (mm)", ylabel="height (m)", title="crack paths, overlaid")
    axes[-1].legend(fontsize=6, loc="lower left")
    fig.tight_layout()
    fig.savefig(out / "tearing_paths.png", dpi=110)
    print(f"results      {out / 'tearing_paths.csv'}\npicture      {out / 'tearing_paths.png'}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--parameter", default="criticalStrain", choices=sorted(DEFAULTS))
    ap.add_argument("--values", help="comma-separated values (default: a sweep around the scene's)")
    ap.add_argument("--out", default="out/tearing_study")
    ap.add_argument("--quick", action="store_true",
                    help="a coarser sheet, three values; with --paths, the first 0.7 s (tests)")
    ap.add_argument("--paths", action="store_true",
                    help="run the sheet five ways that must tear alike and draw the crack paths")
    args = ap.parse_args()
    if args.paths:
        return paths(args)
    values = [float(v) for v in (args.values or DEFAULTS[args.parameter]).split(",")]
    if args.quick and not args.values:
        values = values[:: max(1, len(values) // 3)][:3]
    base = json.loads((ROOT / "data/scenes/tearing.json").read_text())
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    results = []
    for i, v in enumerate(values):
        r = run_one(base, args.parameter, v, args.quick)
        results.append(r)
        print(f"[{i + 1}/{len(values)}] {args.parameter} = {v:g}: crack starts at t = {r['crack_start']:.3f} s, "
              f"sheet parted at t = {r['parted_at']:.3f} s, crack {r['crack_length']:.3f} m, "
              f"peak force {r['peak_force']:.2f} N", file=sys.stderr)

    with open(out / "tearing_study.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow([args.parameter, "crack_start_s", "parted_at_s", "crack_length_m", "peak_force_N", "flagged_steps"])
        for r in results:
            w.writerow([r["value"], r["crack_start"], r["parted_at"], r["crack_length"], r["peak_force"],
                        r["flagged_steps"]])

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    for r in results:
        s = r["series"]
        axes[0].plot(s[:, 0], s[:, 1], label=f"{args.parameter} = {r['value']:g}")
        axes[1].plot(s[:, 0], s[:, 2], label=f"{r['value']:g}")
    axes[0].set(xlabel="time (s)", ylabel="crack length (m)", title="crack growth")
    axes[1].set(xlabel="time (s)", ylabel="right grasp |F| (N)", title="pulling force")
    axes[0].legend(), axes[1].legend()
    v = [r["value"] for r in results]
    axes[2].plot(v, [r["crack_start"] for r in results], "o-", label="crack starts")
    axes[2].plot(v, [r["parted_at"] for r in results], "s-", label="sheet parted")
    axes[2].set(xlabel=args.parameter, ylabel="time (s)", title=f"sweep of {args.parameter}")
    axes[2].legend()
    fig.tight_layout()
    fig.savefig(out / "tearing_study.png", dpi=110)
    print(f"results      {out / 'tearing_study.csv'}\npicture      {out / 'tearing_study.png'}")


if __name__ == "__main__":
    main()
