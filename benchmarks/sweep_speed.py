#!/usr/bin/python3
"""The sweep's speed against running the same runs one after another (docs/sweeps.md, "Speed"):
N runs of the tearing scene (about 1 s each) made three ways, in turn, R rounds: with `cutsim run`
one after another; W at a time with `cutsim run` started by hand (the floor any scheduler meets
on this machine: no Dask, no checks, no extraction); and as one sweep on a local Dask cluster of
W worker processes (its start, the scene checks and the extraction included). Prints each round's
wall times, the ratios to one after another (the target: the sweep at most 0.6 with 2 workers on
2 cores), and the sweep's overhead per run against the floor ((sweep - floor) * W / N).

    PYTHONPATH=build/release/python /usr/bin/python3 benchmarks/sweep_speed.py [--runs 20] [--workers 2] [--rounds 3]
"""
import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--cutsim", default=str(ROOT / "build" / "release" / "src" / "cutsim"))
    a = ap.parse_args()
    import cutsim
    work = pathlib.Path(tempfile.mkdtemp(prefix="cutsim-sweep-speed-"))
    try:
        base = json.loads((ROOT / "data" / "scenes" / "tearing.json").read_text())
        strains = [round(0.06 + 0.08 * i / max(a.runs - 1, 1), 6) for i in range(a.runs)]
        scenes = []
        for i, e in enumerate(strains):
            scene = json.loads(json.dumps(base))
            scene["timeline"][1]["criticalStrain"] = e
            d = work / "scenes" / str(i)
            d.mkdir(parents=True)
            (d / "tearing.json").write_text(json.dumps(scene))
            scenes.append(d / "tearing.json")

        def command(i, tag):
            return [a.cutsim, "run", str(scenes[i]), "--out", str(work / tag / str(i)), "--quiet"]

        def one_after_another(tag):
            start = time.monotonic()
            for i in range(a.runs):
                subprocess.run(command(i, tag), check=True, stdout=subprocess.DEVNULL)
            return time.monotonic() - start

        def by_hand(tag):
            start = time.monotonic()
            running, i = [], 0
            while i < a.runs or running:
                while i < a.runs and len(running) < a.workers:
                    running.append(subprocess.Popen(command(i, tag), stdout=subprocess.DEVNULL))
                    i += 1
                running[0].wait()
                running = [p for p in running if p.poll() is None]
            return time.monotonic() - start

        def swept(tag):
            sweep = {"name": "speed", "scene": str(ROOT / "data" / "scenes" / "tearing.json"),
                     "parameters": [{"pointer": "/timeline/1/criticalStrain", "values": strains}],
                     "extract": [{"name": "crack_start", "first": "points > first"}]}
            start = time.monotonic()
            rows = cutsim.sweep(sweep, results=work / tag, workers=a.workers, progress=False,
                                cutsim_executable=a.cutsim)
            assert all(r["status"] == "done" for r in rows), rows
            return time.monotonic() - start

        print(f"{a.runs} runs of data/scenes/tearing.json, {a.workers} at a time; wall times in s")
        print("round  one-after-another  by-hand-parallel  sweep   by-hand/seq  sweep/seq  overhead/run")
        ratios = []
        for r in range(a.rounds):
            seq = one_after_another(f"seq{r}")
            floor = by_hand(f"hand{r}")
            sw = swept(f"sweep{r}")
            ratios.append((floor / seq, sw / seq, (sw - floor) * a.workers / a.runs))
            print(f"{r:>5}  {seq:17.2f}  {floor:16.2f}  {sw:6.2f}  {floor / seq:11.3f}  {sw / seq:9.3f}  {(sw - floor) * a.workers / a.runs * 1000:9.0f} ms")
        med = [sorted(x)[len(x) // 2] for x in zip(*ratios)]
        print(f"median by hand/seq {med[0]:.3f}, sweep/seq {med[1]:.3f} (target <= 0.6), overhead per run {med[2] * 1000:.0f} ms")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
