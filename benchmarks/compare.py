#!/usr/bin/env python3
"""Interleaved comparison of two builds' Google Benchmark figures.

    benchmarks/compare.py OLD_BINARY NEW_BINARY FILTER [--rounds 7] [--min-time 0.3]

Runs OLD and NEW in turn (old, new, old, new, ...) with the same filter, reads each run's JSON,
and prints per benchmark the median wall-clock time of each side over the rounds and the median
of the round-by-round ratios new/old (so a drift of the shared machine's speed cancels out).
Wall-clock time, not CPU time: Google Benchmark's CPU time is the benchmark thread's own, which
leaves out the work of any other thread it waits for.
"""
import argparse
import json
import statistics
import subprocess
import sys


def run(binary, flt, min_time):
    out = subprocess.run([binary, f"--benchmark_filter={flt}", f"--benchmark_min_time={min_time}",
                          "--benchmark_format=json"], check=True, capture_output=True, text=True).stdout
    return {b["name"]: b["real_time"] for b in json.loads(out)["benchmarks"] if b.get("run_type") != "aggregate"}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("filter")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--min-time", default="0.3")
    a = ap.parse_args()
    old, new = {}, {}
    for r in range(a.rounds):
        for side, binary in ((old, a.old), (new, a.new)):
            for name, t in run(binary, a.filter, a.min_time).items():
                side.setdefault(name, []).append(t)
        print(f"round {r + 1}/{a.rounds} done", file=sys.stderr)
    print(f"{'benchmark':48} {'old (median)':>14} {'new (median)':>14} {'new/old':>8} {'ratio range':>16}")
    for name in old:
        if name not in new:
            continue
        ratios = [n / o for o, n in zip(old[name], new[name])]
        print(f"{name:48} {statistics.median(old[name]):14.4g} {statistics.median(new[name]):14.4g} "
              f"{statistics.median(ratios):8.3f} {min(ratios):7.3f}-{max(ratios):.3f}")


if __name__ == "__main__":
    main()
