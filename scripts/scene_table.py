#!/usr/bin/env python3
"""The table of demo scenes in data/README.md, made from the scenes themselves.

Each row is a scene of data/scenes/: its file, its own "description" and its number of steps
(duration / timeStep, as cutsim counts them). The table sits between the markers
<!-- scenes: begin --> and <!-- scenes: end --> of data/README.md.

    python3 scripts/scene_table.py          # rewrites the table
    python3 scripts/scene_table.py --check  # exits 1, naming the difference, if it is stale

The tests run --check, so that the table never drifts from the scenes.
"""
import json
import math
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
README = ROOT / "data" / "README.md"
BEGIN, END = "<!-- scenes: begin -->", "<!-- scenes: end -->"


def steps(scene):
    """Steps of a scene, as Scene::numSteps counts them."""
    n = scene["duration"] / scene["timeStep"]
    r = round(n)
    return r if abs(n - r) <= 1e-9 * max(1.0, r) else math.ceil(n)


def table():
    rows = ["| file | what it shows (its description) | steps |", "|---|---|---|"]
    for path in sorted((ROOT / "data" / "scenes").glob("*.json")):
        scene = json.loads(path.read_text())
        text = " ".join(scene.get("description", "").split()).replace("|", "\\|")
        if not text:
            sys.exit(f"{path}: the scene has no description")
        rows.append(f"| `scenes/{path.name}` | {text} | {steps(scene)} |")
    return "\n".join(rows) + "\n"


def main():
    text = README.read_text()
    if BEGIN not in text or END not in text:
        sys.exit(f"{README}: the markers {BEGIN} and {END} are missing")
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    new = head + BEGIN + "\n" + table() + END + tail
    if "--check" in sys.argv[1:]:
        if new != text:
            print(f"{README}: the scene table differs from data/scenes/ "
                  "(run python3 scripts/scene_table.py)", file=sys.stderr)
            sys.exit(1)
        return
    README.write_text(new)


if __name__ == "__main__":
    main()
