#!/usr/bin/env python3
"""Contact's cost in CG20 steps, measured side by side on a shared machine.

    benchmarks/contact_cost.py [BINARY] [--rounds 7] [--min-time 1]

BINARY defaults to build/release/benchmarks/cutsim_bench_contact. Each round runs the drape, the
fold and the shifted fold with and without contact in one process (BM_ContactStep/*_with_contact
and *_without_contact, the timed steps reusing the search's cache); per round, contact's cost is
(with - without) / without, in steps without contact (a CG20 step: implicit Euler, CG capped at
20 iterations). Prints the medians over the rounds, the range of the per-round costs, and the
first step's time (the cache's build). Times are wall-clock (Google Benchmark's real time: its CPU
time is the benchmark thread's alone, and leaves out contact's other threads). The targets: at most 0.5 in the drape, 1 in the fold
(its layers aligned, and shifted: see bench_contact.cpp).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys

TARGETS = {"drape": 0.5, "fold": 1.0, "fold_shifted": 1.0}


def run(binary, min_time):
    flt = "BM_ContactStep/(drape|fold|fold_shifted)_with(out)?_contact$"
    out = subprocess.run([binary, f"--benchmark_filter={flt}", f"--benchmark_min_time={min_time}",
                          "--benchmark_format=json"], check=True, capture_output=True, text=True).stdout
    return {b["name"].split("/")[1]: b for b in json.loads(out)["benchmarks"] if b.get("run_type") != "aggregate"}


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("binary", nargs="?", default=os.path.join(here, "..", "build", "release", "benchmarks", "cutsim_bench_contact"))
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--min-time", default="1")
    a = ap.parse_args()
    if not os.path.exists(a.binary):
        sys.exit(f"{a.binary}: no such benchmark binary (build it: scripts/build.sh release)")
    rows = {shape: {"without": [], "with": [], "cost": [], "first": []} for shape in TARGETS}
    for r in range(a.rounds):
        got = run(a.binary, a.min_time)
        for shape, row in rows.items():
            without, with_ = got[f"{shape}_without_contact"], got[f"{shape}_with_contact"]
            row["without"].append(without["real_time"])
            row["with"].append(with_["real_time"])
            row["cost"].append((with_["real_time"] - without["real_time"]) / without["real_time"])
            row["first"].append(with_.get("first_step_ms", float("nan")))
        print(f"round {r + 1}/{a.rounds} done", file=sys.stderr)
    print(f"{'configuration':14} {'without (ms)':>13} {'with (ms)':>10} {'cost (CG20 steps)':>18} {'range':>14} {'target':>7} {'first step (ms)':>16}")
    for shape, row in rows.items():
        cost = statistics.median(row["cost"])
        print(f"{shape:14} {statistics.median(row['without']):13.1f} {statistics.median(row['with']):10.1f} {cost:18.2f} "
              f"{min(row['cost']):6.2f}-{max(row['cost']):<7.2f} {TARGETS[shape]:7.1f} {statistics.median(row['first']):16.0f}")


if __name__ == "__main__":
    main()
