#!/usr/bin/python3
"""A tearing study: the notched sheet of data/scenes/tearing.json pulled apart, run once per value
of a parameter of its fracture (the critical strain, by default), measuring when the crack starts,
how it grows, when the sheet parts and the largest pulling force.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/tearing_study.py
        [--parameter criticalStrain|length|speed|timeStep] [--values 0.06,0.08,...] [--out DIR] [--quick]

Writes DIR/tearing_study.png (crack length and pulling force over time for each value; crack
start and parting time against the value) and DIR/tearing_study.csv (one row per value); DIR
defaults to out/tearing_study.
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
    sim = cutsim.Simulation(scene)
    sim.step(1)  # the notch is cut at t = 0
    initial = boundary_length(sim.rest, sim.triangles())
    series = []  # time, crack length (m), pulling force (N), pieces
    every = max(1, int(round(0.01 / sim.time_step)))
    while not sim.finished:
        sim.step(every)
        tri = sim.triangles()
        crack = (boundary_length(sim.rest, tri) - initial) / 2  # two lips per length of crack
        force = float(np.linalg.norm(sim.grasp_forces().get("right", np.zeros(3))))
        series.append((sim.time, crack, force, pieces(sim.num_slots, tri)))
    s = np.array(series)
    started = s[s[:, 1] > 0.01, 0]
    parted = s[s[:, 3] >= 2, 0]
    return {
        "value": value,
        "crack_start": float(started[0]) if started.size else float("nan"),
        "parted_at": float(parted[0]) if parted.size else float("nan"),
        "crack_length": float(s[-1, 1]),
        "peak_force": float(s[:, 2].max()),
        "flagged_steps": sim.solve_summary["flagged_steps"],
        "series": s,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--parameter", default="criticalStrain", choices=sorted(DEFAULTS))
    ap.add_argument("--values", help="comma-separated values (default: a sweep around the scene's)")
    ap.add_argument("--out", default="out/tearing_study")
    ap.add_argument("--quick", action="store_true", help="a coarser sheet, three values (tests)")
    args = ap.parse_args()
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
