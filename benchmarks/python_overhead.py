#!/usr/bin/python3
"""What stepping from Python costs over `cutsim run`, on the hanging cloth (data/scenes/hanging.json:
676 points, 600 steps of implicit Euler with CG).

    PYTHONPATH=build/release/python /usr/bin/python3 benchmarks/python_overhead.py [--runs 7]
        [--cutsim build/release/src/cutsim] [--scene data/scenes/hanging.json]

Each configuration runs as its own process, the configurations interleaved run after run so that
a busy machine slows them alike. Two figures each, medians and their ratios to `cutsim run`:
  in-process   the time of building the simulation, stepping it and writing its outputs, as
               `cutsim run` reports it ("wall time"; the Python side times the same work from
               before cutsim.load to after finish_recording): what stepping from Python costs
  process      the whole process, start-up included (Python's interpreter and numpy's import,
               about 0.2 s, once per process)
The configurations:
  cli            cutsim run SCENE --quiet (frames and CSV written)
  python         the same from Python: load, record, run, finish_recording
  python+ctrl    the same with a controller called at each step's end (reads sim.time)
  cli-noout      cutsim run on the scene with its outputs off
  python-noout   sim.run() on that scene, from Python
"""
import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]

PY_RUN = """
import sys, time, cutsim
start = time.perf_counter()
sim = cutsim.load(sys.argv[1])
if sys.argv[3] == "ctrl":
    class Tick(cutsim.Controller):
        def on_step_end(self, s):
            s.time
    sim.add_controller(Tick())
if sys.argv[2] != "-":
    sim.record(sys.argv[2])
sim.run()
sim.finish_recording()
print(f"wall time  {time.perf_counter() - start} s")
"""


def timed(cmd, env=None):
    """(in-process seconds as the program reports them, whole-process seconds)."""
    t = time.perf_counter()
    out = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, text=True, env=env).stdout
    whole = time.perf_counter() - t
    inside = next(float(line.split()[2]) for line in out.splitlines() if line.startswith("wall time"))
    return inside, whole


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--cutsim", default=str(ROOT / "build/release/src/cutsim"))
    ap.add_argument("--scene", default=str(ROOT / "data/scenes/hanging.json"))
    args = ap.parse_args()
    env = dict(os.environ)
    env.setdefault("PYTHONPATH", str(ROOT / "build/release/python"))

    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        scene = json.loads(pathlib.Path(args.scene).read_text())
        scene["output"] = {"vtk": False, "csv": False}
        noout = tmp / "noout.json"
        noout.write_text(json.dumps(scene))
        configs = {
            "cli": [args.cutsim, "run", args.scene, "--quiet", "--out", str(tmp / "cli")],
            "python": [sys.executable, "-c", PY_RUN, args.scene, str(tmp / "py"), "-"],
            "python+ctrl": [sys.executable, "-c", PY_RUN, args.scene, str(tmp / "pyc"), "ctrl"],
            "cli-noout": [args.cutsim, "run", str(noout), "--quiet", "--out", str(tmp / "cli2")],
            "python-noout": [sys.executable, "-c", PY_RUN, str(noout), "-", "-"],
        }
        times = {k: [] for k in configs}
        for r in range(args.runs):
            for k, cmd in configs.items():
                times[k].append(timed(cmd, env))
            print(f"run {r + 1}/{args.runs} done", file=sys.stderr)
    print(f"{'':<14} {'in-process':>31}   {'process':>31}")
    print(f"{'configuration':<14}" + f" {'median s':>9} {'min s':>7} {'max s':>7} {'ratio':>6}" * 2)
    for k, v in times.items():
        row = f"{k:<14}"
        base = "cli-noout" if k.endswith("noout") else "cli"
        for i in (0, 1):
            med = statistics.median(t[i] for t in v)
            ref = statistics.median(t[i] for t in times[base])
            row += f" {med:9.3f} {min(t[i] for t in v):7.3f} {max(t[i] for t in v):7.3f} {med / ref:6.3f}"
        print(row)


if __name__ == "__main__":
    main()
