#!/usr/bin/python3
"""A scripted surgery scenario: a scalpel incises a U-shaped flap in a patch of skin, forceps
grasp the flap's tip as soon as it is free and lift it, and a safety controller stops the scalpel
(and holds the forceps) when the force the forceps exert exceeds a limit.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/scripted_surgery.py [--out DIR]
        [--limit NEWTONS] [--quick]

The skin is data/scenes/surgery_incision.json without its timeline: here the scalpel and the
forceps are controllers written in Python (cutsim.Controller), called at the end of each step.
Writes the run's frames and CSV (as `cutsim run` does) to DIR (default out/scripted_surgery),
pictures of it (DIR/render_frames.png, DIR/render_series.png) and DIR/surgery.png (the grasp
force against the limit, and the scalpel's progress along the incision).
"""
import argparse
import json
import math
import pathlib
import subprocess
import sys

import numpy as np

import cutsim

ROOT = pathlib.Path(__file__).resolve().parents[2]


def u_curve(width=0.04, depth=0.04, top=0.0707, center=0.0503, samples=24):
    """The incision: down the left side, around the bottom, up the right side (rest coordinates)."""
    r = width / 2
    bottom = top - depth + r
    pts = [[center - r, top, 0.0], [center - r, bottom, 0.0]]
    for k in range(1, samples):
        a = math.pi + math.pi * k / samples
        pts.append([center + r * math.cos(a), bottom + r * math.sin(a), 0.0])
    pts += [[center + r, bottom, 0.0], [center + r, top, 0.0]]
    return np.array(pts)


class Scalpel(cutsim.Controller):
    """Cuts along a polyline at a constant speed: after each step, the piece covered since the
    last one (pieces of at least `min_piece`, each starting where the previous cut ended)."""

    def __init__(self, polyline, speed, start, min_piece):
        self.polyline = polyline
        seg = np.linalg.norm(np.diff(polyline, axis=0), axis=1)
        self.arc = np.concatenate([[0.0], np.cumsum(seg)])
        self.speed, self.start, self.min_piece = speed, start, min_piece
        self.done = 0.0          # arc length cut so far
        self.tip = polyline[0]   # where the last cut really ended (rest coordinates)
        self.stopped_at = None
        self.history = []        # (time, arc length cut)

    @property
    def length(self):
        return self.arc[-1]

    def point_at(self, s):
        i = min(np.searchsorted(self.arc, s, side="right"), len(self.arc) - 1)
        i = max(i, 1)
        t = (s - self.arc[i - 1]) / max(self.arc[i] - self.arc[i - 1], 1e-300)
        return (1 - t) * self.polyline[i - 1] + t * self.polyline[i]

    def stop(self, sim):
        if self.stopped_at is None:
            self.stopped_at = sim.time

    def on_step_end(self, sim):
        self.history.append((sim.time, self.done))
        if self.stopped_at is not None or self.done >= self.length:
            return
        s = min(self.length, (sim.time - self.start) * self.speed)
        if self.length - s < self.min_piece:
            s = self.length
        if s - self.done < self.min_piece and s < self.length:
            return
        inside = [self.point_at(a) for a in self.arc if self.done < a < s]
        piece = np.array([self.tip, *inside, self.point_at(s)])
        try:
            result = sim.cut(piece)
        except cutsim.TopologyError:
            if s < self.length:
                return  # nothing changed: the scalpel goes on, and cuts a longer piece next step
            raise
        self.tip = sim.rest[result["path"][-1]]
        self.done = s


class Forceps(cutsim.Controller):
    """Grasps the flap's tip once the scalpel has gone round it (past the bottom of the U), then
    lifts it up and back towards the flap's uncut side (`lift` metres up over `duration` seconds,
    starting and ending smoothly). The skin lies on the tissue beneath (the scene's Attachment):
    first the flap is undermined (the dissect action, in the rest-space box `undermine`)."""

    def __init__(self, scalpel, tip, lift, duration, undermine):
        self.scalpel, self.tip, self.lift, self.duration = scalpel, tip, lift, duration
        self.undermine = undermine
        self.grasped = False

    def on_step_end(self, sim):
        if self.grasped or self.scalpel.done < 0.55 * self.scalpel.length:
            return
        s = np.linspace(0, 1, 11)
        ease = s * s * (3 - 2 * s)  # smoothstep: no jolt at the start or the end
        path = [[self.duration * a, 0.0, 0.6 * self.lift * e, self.lift * e] for a, e in zip(s, ease)]
        sim.act({"action": "dissect", "box": self.undermine})
        sim.grasp("forceps", box=[self.tip - [0.005, 0.0035, 1], self.tip + [0.005, 0.0035, 1]], path=path)
        self.grasped = True


class ForceLimit(cutsim.Controller):
    """Stops the scalpel and holds the forceps where they are when the grasp force exceeds the limit."""

    def __init__(self, scalpel, limit):
        self.scalpel, self.limit = scalpel, limit
        self.forces = []  # (time, |force|)
        self.tripped_at = None

    def on_step_end(self, sim):
        f = sim.grasp_forces().get("forceps")
        if f is None:
            return
        magnitude = float(np.linalg.norm(f))
        self.forces.append((sim.time, magnitude))
        if self.tripped_at is None and magnitude > self.limit:
            self.tripped_at = sim.time
            self.scalpel.stop(sim)
            sim.move("forceps", [0, 0, 0])  # hold: no more lifting


def min_angle(points, triangles):
    a, b, c = (points[triangles[:, k]] for k in range(3))
    def angle(p, q, r):
        u, v = q - p, r - p
        cos = np.einsum("ij,ij->i", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
        return np.degrees(np.arccos(np.clip(cos, -1, 1)))
    return float(np.min([angle(a, b, c), angle(b, c, a), angle(c, a, b)]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/scripted_surgery", help="output folder")
    ap.add_argument("--limit", type=float, default=0.2, help="grasp force limit (N)")
    ap.add_argument("--quick", action="store_true", help="a coarser skin and a shorter run (tests)")
    args = ap.parse_args()

    scene = json.loads((ROOT / "data/scenes/surgery_incision.json").read_text())
    scene.pop("timeline")
    scene["name"] = "scripted_surgery"
    scene["description"] = ("The skin of surgery_incision.json, incised and lifted by Python controllers "
                            "(examples/python/scripted_surgery.py)")
    duration = 2.5
    if args.quick:
        scene["mesh"]["grid"].update(nx=16, ny=16)
        scene["timeStep"] = 0.01
        duration = 1.6
    scene["duration"] = duration
    sim = cutsim.Simulation(scene)

    curve = u_curve()
    mean_edge = 0.1 / (scene["mesh"]["grid"]["nx"] - 1)
    scalpel = Scalpel(curve, speed=0.1, start=0.1, min_piece=0.5 * mean_edge)
    forceps = Forceps(scalpel, tip=np.array([0.0503, 0.0375, 0.0]), lift=0.03, duration=0.8,
                      undermine=[[0.028, 0.028, -1.0], [0.0725, 0.0725, 1.0]])
    limit = ForceLimit(scalpel, args.limit)
    for c in (scalpel, forceps, limit):
        sim.add_controller(c)

    out = pathlib.Path(args.out)
    sim.record(out, grasps=["forceps"])  # the CSV gets the forceps' force columns
    total = sim.num_steps
    for k in range(10):  # progress, a tenth at a time
        sim.run_until(duration * (k + 1) / 10)
        f = limit.forces[-1][1] if limit.forces else 0.0
        print(f"{100 * sim.step_count // total:3d}%  t = {sim.time:.2f} s  cut {1000 * scalpel.done:5.1f} of "
              f"{1000 * scalpel.length:.1f} mm  grasp force {f:.3f} N", file=sys.stderr)
    sim.finish_recording()

    points, triangles, _ = sim.surface()
    rest = sim.rest[np.flatnonzero(sim.alive)]
    peak = max((f for _, f in limit.forces), default=0.0)
    print(f"scene        {sim.name}: {sim.num_points} points, {sim.num_triangles} triangles at t = {sim.time:.2f} s")
    print(f"incision     {1000 * scalpel.done:.1f} of {1000 * scalpel.length:.1f} mm cut"
          + (f"; the scalpel stopped at t = {scalpel.stopped_at:.3f} s" if scalpel.stopped_at else ""))
    print(f"forceps      peak force {peak:.3f} N (limit {args.limit} N)"
          + (f", limit reached at t = {limit.tripped_at:.3f} s" if limit.tripped_at else ", limit not reached"))
    print(f"mesh         smallest triangle angle {min_angle(rest, triangles):.1f} degrees (rest), "
          f"flap lifted to z = {1000 * points[:, 2].max():.1f} mm")
    print(f"solver       {sim.solve_summary['flagged_steps']} flagged steps")

    # Pictures: the run's frames and series (scripts/render.py), and the controllers' story.
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 3.8))
    if limit.forces:
        t, f = np.array(limit.forces).T
        a1.plot(t, f, label="grasp force |F|")
    a1.axhline(args.limit, color="r", ls="--", label="limit")
    if limit.tripped_at:
        a1.axvline(limit.tripped_at, color="k", lw=0.8, label="scalpel stopped")
    a1.set_xlabel("time (s)"), a1.set_ylabel("N"), a1.legend(), a1.set_title("forceps")
    t, s = np.array(scalpel.history).T
    a2.plot(t, 1000 * s)
    a2.axhline(1000 * scalpel.length, color="gray", ls=":", label="whole incision")
    a2.set_xlabel("time (s)"), a2.set_ylabel("mm cut"), a2.legend(), a2.set_title("scalpel")
    fig.tight_layout()
    fig.savefig(out / "surgery.png", dpi=110)
    subprocess.run([sys.executable, str(ROOT / "scripts/render.py"), str(out), "--view", "40,-70"],
                   check=True, stdout=subprocess.DEVNULL)
    print(f"pictures     {out / 'render_frames.png'}, {out / 'render_series.png'}, {out / 'surgery.png'}")


if __name__ == "__main__":
    main()
