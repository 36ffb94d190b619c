"""The Python examples run to the end (quick settings) and write what they promise."""
import os
import pathlib
import subprocess
import sys

import pytest

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples" / "python"


def run(script, *args):
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run([sys.executable, str(EXAMPLES / script), *args], env=env, check=True,
                          capture_output=True, text=True, timeout=600)


def test_scripted_surgery(tmp_path):
    r = run("scripted_surgery.py", "--quick", "--out", str(tmp_path), "--limit", "0.05")
    assert "the scalpel stopped at t =" in r.stdout and "limit reached" in r.stdout, r.stdout + r.stderr
    for name in ("steps.csv", "surface.pvd", "surgery.png", "render_frames.png", "render_series.png"):
        assert (tmp_path / name).stat().st_size > 0, name


def test_tearing_study(tmp_path):
    r = run("tearing_study.py", "--quick", "--out", str(tmp_path))
    rows = (tmp_path / "tearing_study.csv").read_text().splitlines()
    assert rows[0].startswith("criticalStrain,") and len(rows) == 4, r.stdout + r.stderr
    assert (tmp_path / "tearing_study.png").stat().st_size > 0


def test_tearing_paths(tmp_path):
    """The notched sheet run five ways (the scene, dt / 4, the other diagonals, h / 2, explicit):
    each crack starts within 10% of the same time, is as deep within a cell at the end, and its
    path stays within a cell of the first run's (and of the notch axis)."""
    import csv
    import math
    run("tearing_study.py", "--paths", "--quick", "--out", str(tmp_path))
    rows = list(csv.DictReader((tmp_path / "tearing_paths.csv").open()))
    assert [r["run"] for r in rows][-1].startswith("explicit") and len(rows) == 5
    first = rows[0]
    cell = 1.0 / 25
    for r in rows:
        assert abs(float(r["crack_start_s"]) - float(first["crack_start_s"])) <= 0.1 * float(first["crack_start_s"]), r
        assert float(r["crack_depth_m"]) > 3 * cell, r
        assert abs(float(r["crack_depth_m"]) - float(first["crack_depth_m"])) < cell, r
        assert float(r["largest_offset_cells"]) < 1.0, r
        assert int(r["bands_compared"]) >= 3 and float(r["gap_to_first_cells"]) < 1.0, r
        assert all(math.isfinite(float(r[k])) for k in ("crack_start_s", "crack_depth_m", "gap_to_first_cells")), r
        assert r["flagged_steps"] == "0", r
    assert (tmp_path / "tearing_paths.png").stat().st_size > 0


def test_scripted_surgery_as_documented(tmp_path):
    """The default run, with the figures docs/python.md quotes (within what another machine's
    rounding may move)."""
    import re
    r = run("scripted_surgery.py", "--out", str(tmp_path))
    m = re.search(r"incision\s+([\d.]+) of ([\d.]+) mm cut\n", r.stdout)
    assert m, r.stdout
    cut, total = map(float, m.groups())
    assert abs(cut - total) < 0.1 and abs(total - 102.8) < 0.1, r.stdout
    peak = float(re.search(r"peak force ([\d.]+) N \(limit 0.2 N\), limit not reached", r.stdout).group(1))
    assert 0.1 < peak < 0.2, r.stdout
    assert float(re.search(r"flap lifted to z = ([\d.]+) mm", r.stdout).group(1)) > 25, r.stdout
    assert float(re.search(r"smallest triangle angle ([\d.]+)", r.stdout).group(1)) >= 19.9
    assert "forceps_fx" in (tmp_path / "steps.csv").read_text().splitlines()[0]


def test_energy_balance(tmp_path):
    r = run("energy_balance.py", "--quick", "--out", str(tmp_path))
    rows = (tmp_path / "energy_integrators.csv").read_text().splitlines()
    assert rows[0] == "integrator,time_step,final_drift,largest_drift" and len(rows) == 9, r.stdout
    drift = {}
    for line in rows[1:]:
        name, dt, final, largest = line.split(",")
        drift[(name, float(dt))] = float(final)
    # Implicit Euler only loses energy, and less at half the step; BDF2 far less at the same step.
    assert 0.8 * drift[("implicit-euler", 4e-4)] < drift[("implicit-euler", 2e-4)] < 0
    assert abs(drift[("bdf2", 4e-4)]) < 0.2 * abs(drift[("implicit-euler", 4e-4)])
    assert (tmp_path / "energy_tearing.csv").read_text().startswith("run,time,kinetic,stored,")
    assert (tmp_path / "energy_balance.png").stat().st_size > 0
