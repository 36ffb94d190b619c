#!/usr/bin/python3
"""Where the energy goes: the energy accounts (docs/energy.md) of two runs.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/energy_balance.py [--out DIR] [--quick]

1. Each integrator's own error. A free 1 m sheet whose springs are 10% shorter than its mesh is let
   go and rings for 0.05 s, with each integrator at three time steps (symplectic Euler at four).
   Nothing does work on it and nothing damps it, so the balance
   (stored + dissipated + removed - work) should stay where it starts: what it drifts by is the
   integrator's error. DIR/energy_integrators.csv: integrator, time step, the final and the largest
   drift as a fraction of the starting energy.
2. The tearing demo (data/scenes/tearing.json, its StretchSprings and the same sheet as a
   TriangularFEM membrane): the grasps' work, what damping dissipated, what the cracks removed or
   added (a spring network cut through its triangles under strain gains springs that are born
   stretched: energy added; a membrane's elements only divide), the stored energy and the drift,
   implicit Euler's numerical dissipation, over time. DIR/energy_tearing.csv (one row per run and
   0.01 s) and DIR/energy_balance.png.
"""
import argparse
import csv
import json
import pathlib

import cutsim

ROOT = pathlib.Path(__file__).resolve().parents[2]


def ringing(integrator, dt, duration):
    return {
        "mesh": {"grid": {"nx": 9, "ny": 9, "size": [1, 1]}},
        "mass": {"total": 0.1},
        "forceFields": [{"type": "StretchSprings", "stiffness": 50, "restScale": 0.9},
                        {"type": "FastTriangularBendingSprings", "bendingStiffness": 0.001}],
        "integrator": {"type": integrator},
        **({} if integrator == "explicit-euler" else {"linearSolver": {"type": "cholmod"}}),
        "timeStep": dt, "duration": duration,
        "output": {"energy": True},
    }


def integrator_table(quick):
    duration = 0.01 if quick else 0.05
    cases = [("explicit-euler", [1e-4, 5e-5] if quick else [4e-4, 2e-4, 1e-4, 5e-5])]
    for name in ("implicit-euler", "bdf2", "newton"):
        cases.append((name, [4e-4, 2e-4] if quick else [4e-4, 2e-4, 1e-4]))
    rows = []
    for name, steps in cases:
        for dt in steps:
            sim = cutsim.Simulation(ringing(name, dt, duration))
            start = sim.energy_account()["stored"]
            worst = 0.0
            while not sim.finished:
                sim.step(1)
                worst = max(worst, abs(sim.energy_account()["drift"]))
            final = sim.energy_account()["drift"]
            rows.append({"integrator": name, "time_step": dt, "final_drift": final / start,
                         "largest_drift": worst / start})
            print(f"{name:15s} dt = {dt:g} s: drift {100 * final / start:+.3f}% of the starting "
                  f"energy at the end, {100 * worst / start:.3f}% at most")
    return rows


TEARING_RUNS = [
    ("StretchSprings (the demo)", None),
    ("TriangularFEM membrane", {"type": "TriangularFEM", "youngModulus": 2e4, "poissonRatio": 0.3,
                                "thickness": 0.1}),
]


def tearing_runs(quick):
    base = json.loads((ROOT / "data" / "scenes" / "tearing.json").read_text())
    series = []
    for label, membrane in TEARING_RUNS:
        scene = json.loads(json.dumps(base))
        scene["output"] = {"energy": True}
        if membrane:
            scene["forceFields"][0] = membrane
        if quick:
            scene["mesh"]["grid"].update(nx=18, ny=18)
            scene["duration"] = 1.3
        sim = cutsim.Simulation(scene, base_dir=ROOT / "data" / "scenes")
        every = max(1, int(round(0.01 / sim.time_step)))
        while not sim.finished:
            sim.step(every)
            a = sim.energy_account()
            series.append({"run": label, "time": sim.time, "kinetic": sim.energies()["kinetic"],
                           "stored": a["stored"], "work_constraints": a["work_constraints"],
                           "dissipated_damping": a["dissipated_damping"], "removed": a["removed"],
                           "drift": a["drift"]})
        last = series[-1]
        print(f"{label}: the grasps did {last['work_constraints']:.3g} J of work; damping "
              f"dissipated {last['dissipated_damping']:.3g} J; the cracks removed "
              f"{last['removed']:.3g} J; {last['stored']:.3g} J stored at the end; the balance "
              f"drifted by {last['drift']:.3g} J (implicit Euler's numerical dissipation)")
    return series


def plot(series, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = [label for label, _ in TEARING_RUNS]
    fig, axes = plt.subplots(1, len(runs), figsize=(6 * len(runs), 4.5), sharey=True)
    for ax, label in zip(axes, runs):
        rows = [r for r in series if r["run"] == label]
        t = [r["time"] for r in rows]
        for key, name in (("work_constraints", "work of the grasps"), ("stored", "stored"),
                          ("dissipated_damping", "dissipated by damping"),
                          ("removed", "removed by the cracks"), ("drift", "drift (integrator)"),
                          ("kinetic", "kinetic")):
            ax.plot(t, [r[key] for r in rows], label=name)
        ax.set_title(f"tearing sheet: {label}")
        ax.set_xlabel("time (s)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("energy (J)")
    axes[0].legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "out" / "energy_balance"))
    parser.add_argument("--quick", action="store_true", help="shorter runs, a coarser sheet")
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table = integrator_table(args.quick)
    with open(out / "energy_integrators.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(table[0]))
        w.writeheader()
        w.writerows(table)
    series = tearing_runs(args.quick)
    with open(out / "energy_tearing.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(series[0]))
        w.writeheader()
        w.writerows(series)
    plot(series, out / "energy_balance.png")
    print(f"wrote {out / 'energy_integrators.csv'}, {out / 'energy_tearing.csv'} and "
          f"{out / 'energy_balance.png'}")


if __name__ == "__main__":
    main()
