"""Scenes from files and dicts, stepping, and equality with `cutsim run`."""
import json
import subprocess

import numpy as np
import pytest

import cutsim


def read_obj_vertices(path):
    return np.array([[float(t) for t in line.split()[1:4]]
                     for line in open(path) if line.startswith("v ")])


def test_load_file_and_dict_agree(tmp_path, small_scene):
    f = tmp_path / "small.json"
    f.write_text(json.dumps(small_scene))
    a = cutsim.load(f)
    b = cutsim.Simulation(small_scene)
    assert a.name == b.name == "small"
    a.step(20)
    b.step(20)
    assert a.step_count == b.step_count == 20
    assert a.time == pytest.approx(20 * 0.005, rel=0, abs=1e-15)
    np.testing.assert_array_equal(a.x, b.x)
    assert a.x.shape == (81, 3)


@pytest.mark.parametrize("change, pointer, words", [
    (lambda s: s["forceFields"][1].update(bendingStiffness=-1), "/forceFields/1/bendingStiffness", ">= 0"),
    (lambda s: s["forceFields"].append({"type": "NoSuchField"}), "/forceFields/2/type", "NoSuchField"),
    (lambda s: s.pop("timeStep"), "/", "timeStep"),
    (lambda s: s["mesh"]["grid"].update(nx=1), "/mesh/grid/nx", ""),
    (lambda s: s.update(timeline=[{"at": 0.1, "action": "cut", "polyline": [[5, 5, 0], [6, 5, 0]]}]),
     "/timeline/0/polyline/0", "misses the surface"),
])
def test_bad_scene_dict_names_the_pointer(small_scene, change, pointer, words):
    change(small_scene)
    with pytest.raises(cutsim.InvalidInputError) as e:
        cutsim.Simulation(small_scene)
    message = str(e.value)
    assert message.startswith("<scene dict>:"), message
    assert pointer + ":" in message, message
    assert words in message, message
    assert isinstance(e.value, ValueError)


def test_same_message_as_a_scene_file(tmp_path, small_scene):
    small_scene["forceFields"][0]["stiffness"] = "stiff"
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(small_scene, indent=1))
    with pytest.raises(cutsim.InvalidInputError) as from_file:
        cutsim.load(f)
    with pytest.raises(cutsim.InvalidInputError) as from_dict:
        cutsim.Simulation(small_scene)
    # The same line (both are one value per line) and message; only the source's name differs.
    assert str(from_file.value).replace(str(f), "<scene dict>") == str(from_dict.value)


def test_missing_file():
    with pytest.raises(cutsim.InvalidInputError, match="cannot open the scene file"):
        cutsim.load("/nonexistent/scene.json")


def test_bit_identical_to_cutsim_run(tmp_path, cutsim_program, source_dir):
    """The cut cloth of the README's demo, shortened to just after the cut: stepped from Python
    and recorded, it gives the same final positions (17 digits) and byte-identical outputs."""
    scene = json.loads((source_dir / "data/scenes/hanging_cut.json").read_text())
    scene["duration"] = 1.6
    f = tmp_path / "scene.json"
    f.write_text(json.dumps(scene))
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    subprocess.run([cutsim_program, "run", str(f), "--out", str(cli_out), "--dump-final", str(cli_out / "final"),
                    "--quiet"], check=True, capture_output=True)

    sim = cutsim.load(f)
    sim.record(py_out)
    sim.run()
    assert sim.finished and sim.cuts_done == 1
    sim.finish_recording()
    sim.dump_final(py_out / "final")

    points, _, _ = sim.surface()
    np.testing.assert_array_equal(points, read_obj_vertices(cli_out / "final" / "final.obj"))
    names = sorted(p.name for p in cli_out.iterdir() if p.is_file())
    assert names == sorted(p.name for p in py_out.iterdir() if p.is_file())
    assert "steps.csv" in names and len(names) > 30
    for name in names:
        assert (cli_out / name).read_bytes() == (py_out / name).read_bytes(), name
    for name in ("final.obj", "final_rest.obj", "final_forces.json"):
        assert (cli_out / "final" / name).read_bytes() == (py_out / "final" / name).read_bytes(), name


def test_run_until_and_past_the_duration(small_scene):
    sim = cutsim.Simulation(small_scene)
    sim.run_until(0.1)
    assert sim.step_count == 20
    sim.run()
    assert sim.finished and sim.step_count == 100
    sim.step(3)  # scripts may run on
    assert sim.step_count == 103
    assert sim.time == pytest.approx(0.515)


def test_time_step_change(small_scene):
    sim = cutsim.Simulation(small_scene)
    sim.step(10)
    sim.time_step = 0.0025
    sim.step(4)
    assert sim.time == pytest.approx(0.06)
    with pytest.raises(cutsim.InvalidInputError):
        sim.time_step = -1
    assert np.isfinite(sim.x).all()


def test_solver_failure_raises_and_keeps_the_state(small_scene):
    small_scene.pop("linearSolver")
    small_scene["integrator"] = {"type": "explicit-euler"}
    small_scene["forceFields"][0]["stiffness"] = 1e9
    small_scene["timeStep"] = 0.05
    sim = cutsim.Simulation(small_scene)
    with pytest.raises(cutsim.SolverError, match="non-finite") as e:
        sim.step(200)
    assert isinstance(e.value, RuntimeError)
    assert np.isfinite(sim.x).all() and np.isfinite(sim.v).all()


def test_missed_tolerance_warns(small_scene):
    small_scene["linearSolver"] = {"type": "cg", "iterations": 2, "tolerance": 1e-12}
    sim = cutsim.Simulation(small_scene)
    with pytest.warns(cutsim.SolverWarning, match="flagged"):
        sim.step(5)
    assert sim.solve_summary["missed_tolerance"] == 5
    assert sim.last_stats["flags"].startswith("missed-tolerance")


def test_energy_account(small_scene):
    sim = cutsim.Simulation(small_scene)
    assert sim.energy_account() is None  # off unless asked for
    sim.step(3)
    sim.account_energy()
    sim.step(20)
    a = sim.energy_account()
    assert set(a) >= {"stored", "balance", "drift", "work_gravity", "work_constraints", "work_contact",
                      "dissipated_damping", "removed", "step"}
    e = sim.energies()
    # Gravity's work is the fall of the weight since the accounts opened; the drift, implicit
    # Euler's loss, is a small part of it and never a gain.
    assert a["work_gravity"] > 0 and -0.2 * a["work_gravity"] < a["drift"] <= 1e-12
    assert a["stored"] == pytest.approx(e["kinetic"] + e["StretchSprings"] + e["FastTriangularBendingSprings"])
    assert set(a["step"]) == {"work_gravity", "work_constraints", "work_contact", "dissipated_damping",
                              "removed", "drift"}
    small_scene["output"] = {"energy": True}
    assert cutsim.Simulation(small_scene).energy_account()["drift"] == 0.0


def test_energies_forces_and_bending_eval(small_scene):
    sim = cutsim.Simulation(small_scene)
    sim.step(30)
    e = sim.energies()
    assert set(e) == {"kinetic", "gravity", "StretchSprings", "FastTriangularBendingSprings"}
    assert e["kinetic"] > 0
    f = sim.forces()
    assert f.shape == sim.x.shape and np.isfinite(f).all()
    # The bending springs' force is minus the gradient of their energy (central differences).
    energy, force = sim.eval_bending()
    x = np.array(sim.x)
    rng = np.random.default_rng(3)
    for p in rng.choice(np.flatnonzero(sim.alive), 6, replace=False):
        for c in range(3):
            h = 1e-6
            xp, xm = x.copy(), x.copy()
            xp[p, c] += h
            xm[p, c] -= h
            fd = -(sim.eval_bending(xp)[0] - sim.eval_bending(xm)[0]) / (2 * h)
            assert force[p, c] == pytest.approx(fd, rel=1e-5, abs=1e-9)
    assert energy == pytest.approx(e["FastTriangularBendingSprings"])
    with pytest.raises(cutsim.InvalidInputError, match="no force field labelled"):
        sim.eval("Nope")
    with pytest.raises(ValueError, match="shape"):
        sim.eval_bending(np.zeros((3, 3)))


def test_a_sofa_scene_loads_and_steps_as_its_run():
    """cutsim.load reads SOFA's .scn as `cutsim run` does (docs/sofa.md)."""
    import pathlib
    scn = pathlib.Path(__file__).resolve().parents[1] / "data" / "sofa-scenes" / "FastTriangularBendingSprings.scn"
    s = cutsim.load(scn)
    assert s.name == "FastTriangularBendingSprings"
    s.step(10)
    assert s.x.shape == (100, 3)
    assert s.x[:, 2].min() < 0  # the free side sags under gravity -z
    assert s.x[:10, 2].max() == 0  # the row the BoxROI holds stays
