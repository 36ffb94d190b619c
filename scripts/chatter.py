#!/usr/bin/env python3
"""Step-by-step motion of a scene while a grasp moves: does the surface chatter?

Frames written every N steps hide an oscillation of period two (every even step looks alike), so
this steps the scene through the Python module and looks at every step:

- chatter: for each step n, the median over the moving points of |x(n+1) - x(n)| over the median
  of |x(n+1) - x(n-1)| / 2; the median of that over the steps. 1 for smooth motion, large when the
  points jump back and forth every step.
- speed: the median point speed (|x(n+1) - x(n)| / dt) over the steps, against the grasp's speed.
- grasp force: the lag-one autocorrelation of the grasp's force magnitude over the window (mean
  removed: near 1 for a force that changes smoothly, near -1 for one that alternates every step),
  and that of its changes from step to step (stricter: a kink of the grasp's path rings there).

Usage (the module built for Debian's interpreter):
  PYTHONPATH=build/release/python /usr/bin/python3 scripts/chatter.py data/scenes/surgery_incision.json \
      --grasp forceps --from 1.35 --to 2.8 [--set /forceFields/0/tangent=corotational] [--csv OUT.csv]
Prints the figures (and writes them per step with --csv); exit 0.
"""
import argparse
import json
import math
import os
import sys

import numpy as np

import cutsim


def set_pointer(doc, pointer, value):
    parts = [p.replace("~1", "/").replace("~0", "~") for p in pointer.strip("/").split("/")]
    node = doc
    for p in parts[:-1]:
        node = node[int(p)] if isinstance(node, list) else node[p]
    last = parts[-1]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value


def parse_value(text):
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def lag_one_autocorrelation(series):
    d = np.asarray(series, dtype=float)
    d = d - d.mean()
    den = float(np.dot(d, d))
    return float(np.dot(d[:-1], d[1:]) / den) if den > 0 else float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--grasp", default="forceps", help="the grasp whose force and speed to compare")
    ap.add_argument("--from", dest="t0", type=float, required=True, help="start of the window (s)")
    ap.add_argument("--to", dest="t1", type=float, required=True, help="end of the window (s)")
    ap.add_argument("--set", action="append", default=[], metavar="/POINTER=VALUE",
                    help="change a key of the scene (JSON value, or a string)")
    ap.add_argument("--csv", help="write the per-step figures here")
    args = ap.parse_args()

    with open(args.scene) as f:
        doc = json.load(f)
    for s in args.set:
        pointer, _, value = s.partition("=")
        set_pointer(doc, pointer, parse_value(value))
    sim = cutsim.Simulation(doc, base_dir=os.path.dirname(os.path.abspath(args.scene)))
    dt = sim.time_step
    sim.run_until(args.t0 - 2 * dt)

    xs, forces, times, centres = [], [], [], []
    while sim.time < args.t1 - 1e-12:
        sim.step()
        view = sim.view()
        alive = np.asarray(view.alive, dtype=bool)
        x = np.array(view.x)
        x[~alive] = np.nan
        xs.append(x)
        times.append(sim.time)
        g = sim.grasp_forces().get(args.grasp)
        forces.append(float(np.linalg.norm(g)) if g is not None else float("nan"))
        try:
            held = np.asarray(sim.grasp_points(args.grasp), dtype=int)
            centres.append(x[held].mean(axis=0) if held.size else None)
        except Exception:  # the grasp is not there (yet, or any more)
            centres.append(None)

    ratios, speeds, rows = [], [], []
    for n in range(1, len(xs) - 1):
        a, b, c = xs[n - 1], xs[n], xs[n + 1]
        if a.shape != c.shape:
            continue  # a topology change renumbered the slots
        one = np.linalg.norm(c - b, axis=1)
        two = np.linalg.norm(c - a, axis=1)
        # the points that move (held and fixed ones do not), the same set for both medians
        ok = np.isfinite(one) & np.isfinite(two) & ((one > 1e-12) | (two > 1e-12))
        if not ok.any():
            continue
        med_one = float(np.median(one[ok]))
        med_two = float(np.median(two[ok]))
        ratio = med_one / (0.5 * med_two) if med_two > 0 else float("nan")
        speed = med_one / dt
        ratios.append(ratio)
        speeds.append(speed)
        rows.append((times[n], ratio, speed, forces[n]))

    grasp_speed = float("nan")
    held = [c for c in centres if c is not None]
    if len(held) > 2:
        p = np.array(held, dtype=float)
        grasp_speed = float(np.median(np.linalg.norm(np.diff(p, axis=0), axis=1)) / dt)

    result = {
        "scene": args.scene,
        "changes": args.set,
        "steps": len(rows),
        "chatter_median": float(np.median(ratios)) if ratios else float("nan"),
        "median_point_speed": float(np.median(speeds)) if speeds else float("nan"),
        "p90_point_speed": float(np.percentile(speeds, 90)) if speeds else float("nan"),
        "grasp_speed": grasp_speed,
        "grasp_force_lag1_autocorrelation": lag_one_autocorrelation(
            [f for f in forces if math.isfinite(f)]),
        "grasp_force_changes_lag1_autocorrelation": lag_one_autocorrelation(
            np.diff([f for f in forces if math.isfinite(f)])),
        "grasp_force_mean": float(np.nanmean(forces)) if forces else float("nan"),
    }
    print(json.dumps(result, indent=2))
    if args.csv:
        with open(args.csv, "w") as f:
            f.write("time,chatter,median_speed,grasp_force\n")
            for r in rows:
                f.write("%.6f,%.6g,%.6g,%.6g\n" % r)
    return 0


if __name__ == "__main__":
    sys.exit(main())
