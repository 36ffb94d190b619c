"""Hostile use: wrong types and values, failures in the middle of a run, threads, garbage
collection. Each must end in a clear error or the documented behaviour, never a crash."""
import gc
import threading
import warnings
import weakref

import numpy as np
import pytest

import cutsim


@pytest.mark.parametrize("value", ["abc", {}, object(), [1, 2], None, [0, 0, np.inf]])
def test_bad_vectors_raise(small_scene, value):
    sim = cutsim.Simulation(small_scene)
    with pytest.raises((ValueError, TypeError), match="gravity"):
        sim.gravity = value
    sim.grasp("g", points=[40])
    with pytest.raises((ValueError, TypeError), match="delta"):
        sim.move("g", value)


def test_bad_selections_raise(small_scene):
    sim = cutsim.Simulation(small_scene)
    with pytest.raises(TypeError, match="points"):
        sim.grasp("g", points=[1.7])
    with pytest.raises(ValueError, match="near"):
        sim.grasp("g", near=[1, 2])
    with pytest.raises(ValueError, match="box"):
        sim.fix(box=[0, 0, 0])
    sim.remove(sphere=([0.5, 0.5, 0], 0.2), boundary="centroid")
    dead = int(np.flatnonzero(~sim.alive)[0])
    with pytest.raises(cutsim.InvalidInputError, match=f"point {dead} is not a live point"):
        sim.fix(points=[dead])
    with pytest.raises(ValueError, match="min_angle"):
        sim.tear(0, min_angle=75)
    with pytest.raises(ValueError, match="1e12 steps"):
        sim.run_until(1e30)


def test_non_finite_numbers_name_their_place(small_scene):
    small_scene["forceFields"][1]["bendingStiffness"] = float("nan")
    with pytest.raises(cutsim.InvalidInputError, match=r"<scene dict>: /forceFields/1/bendingStiffness: nan"):
        cutsim.Simulation(small_scene)
    small_scene["forceFields"][1]["bendingStiffness"] = 0.01
    sim = cutsim.Simulation(small_scene)
    with pytest.raises(cutsim.InvalidInputError, match=r"<action cut>: /polyline/1/0: inf"):
        sim.act({"action": "cut", "polyline": [[0, 0.5, 0], [np.inf, 0.5, 0]]})
    with pytest.raises(cutsim.InvalidInputError, match="/stiffness: nan"):
        sim.set_parameters("StretchSprings", stiffness=np.nan)


def test_a_folder_is_not_a_scene(tmp_path):
    with pytest.raises(cutsim.InvalidInputError, match="is a folder, not a scene file"):
        cutsim.load(tmp_path)


def test_labels_and_types(small_scene):
    small_scene["forceFields"][1]["label"] = "bend"
    sim = cutsim.Simulation(small_scene)
    assert sim.field_labels == ["StretchSprings", "bend"]
    assert sim.field_types == ["StretchSprings", "FastTriangularBendingSprings"]
    assert sim.eval_bending()[0] == sim.eval("bend")[0]
    with pytest.raises(cutsim.InvalidInputError, match="label cannot change"):
        sim.set_parameters("bend", label="other")


def test_a_failing_action_leaves_the_run_going(small_scene, tmp_path):
    sim = cutsim.Simulation(small_scene)
    sim.record(tmp_path)
    # A progressive cut whose end is off the surface: it fails when the scalpel gets there.
    sim.act({"action": "cut", "from": 0.0, "to": 0.1, "polyline": [[0.3, 0.5, 0], [0.5, 0.5, 0], [3, 0.5, 0]]})
    sim.act({"action": "release", "at": 0.05, "name": "nobody"})
    sim.act({"action": "tearing", "at": 0.05, "threshold": 10})
    failures = []
    for _ in range(40):
        try:
            sim.step()
        except cutsim.Error as e:
            failures.append((sim.step_count, str(e)))
    # Each failing action fails once, names itself, and leaves the timeline; the steps go on.
    assert [f[0] for f in failures] == sorted({f[0] for f in failures})
    assert any("<action release>" in m and "no grasp named \"nobody\"" in m for _, m in failures), failures
    assert any("<action cut>" in m and "the cut failed" in m for _, m in failures), failures
    assert len(failures) == 2 and sim.step_count == 40
    sim.finish_recording()
    rows = (tmp_path / "steps.csv").read_text().splitlines()
    assert len(rows) == 1 + 41  # the header, t = 0 and every step, failed actions or not


def test_time_step_change_moves_the_end(small_scene):
    sim = cutsim.Simulation(small_scene)
    sim.step(50)  # t = 0.25 of 0.5
    sim.time_step = 0.01
    assert sim.num_steps == 50 + 25
    sim.run()
    assert sim.finished and sim.time == pytest.approx(0.5)


def test_frames_past_the_end_keep_their_spacing(small_scene, tmp_path):
    sim = cutsim.Simulation(small_scene)
    sim.record(tmp_path)
    sim.run()  # 100 steps, a frame every 10
    sim.step(25)
    sim.finish_recording()  # and one of the last step
    frames = sorted(tmp_path.glob("surface_*.vtp"))
    assert len(frames) == 11 + 2 + 1


def test_callback_error_during_record_is_raised_by_record(small_scene, tmp_path):
    small_scene["timeline"] = [{"at": 0, "action": "cut", "polyline": [[0, 0.5, 0], [0.5, 0.5, 0]]}]
    sim = cutsim.Simulation(small_scene)

    def broken(ev):
        raise KeyError("callback")

    sim.on_topology_event(broken)
    with pytest.raises(KeyError):
        sim.record(tmp_path)
    sim.remove_topology_callback(broken)
    sim.step()


def test_cycles_through_callbacks_are_collected(small_scene):
    refs = []
    for _ in range(3):
        sim = cutsim.Simulation(small_scene)
        sim.on_topology_event(lambda ev, s=sim: s.time)

        class Holder(cutsim.Controller):
            def __init__(self, s):
                self.s = s

            def on_step_end(self, s):
                pass

        sim.add_controller(Holder(sim))
        refs.append(weakref.ref(sim))
        del sim
    gc.collect()
    assert all(r() is None for r in refs)


def test_other_threads_are_refused_while_it_steps():
    scene = {
        "mesh": {"grid": {"nx": 40, "ny": 40}}, "mass": {"total": 0.2}, "gravity": [0, 0, -9.81],
        "forceFields": [{"type": "StretchSprings", "stiffness": 1000}],
        "constraints": [{"type": "fixed", "near": [[0, 1, 0]]}], "linearSolver": {"type": "cholmod"},
        "timeStep": 0.005, "duration": 1,
    }
    sim = cutsim.Simulation(scene)
    done = threading.Event()
    errors = []

    def stepper():
        try:
            sim.step(60)
        except Exception as e:  # pragma: no cover - reported below
            errors.append(e)
        done.set()

    t = threading.Thread(target=stepper)
    t.start()
    refused = 0
    calls = [lambda: sim.cut([[0, 0.5, 0], [0.4, 0.5, 0]]), lambda: sim.x, lambda: sim.finish_recording(),
             lambda: sim.grasp_forces(), lambda: sim.eval("StretchSprings"), lambda: sim.step()]
    while not done.is_set():
        for call in calls:
            try:
                call()
            except cutsim.UsageError:
                refused += 1
    t.join()
    assert errors == [] and sim.step_count >= 60 and sim.validate() == []  # 61: a step() just after the loop
    assert refused > 0


def test_forces_in_callbacks_wait_for_the_transaction_end(small_scene):
    sim = cutsim.Simulation(small_scene)
    sim.set_parameters("StretchSprings", stiffness=900)  # a field rebuilt: subscribed anew
    sim.remove(sphere=([0.5, 0.5, 0], 0.35))
    seen = []

    def reader(ev):
        if ev.kind == "transaction_end":
            seen.append((sim.energies()["StretchSprings"], np.array(sim.forces())))
            # Every table has followed the operation: the views have the topology's layout.
            assert sim.x.shape == (sim.num_slots, 3) and int(sim.alive.sum()) == sim.num_points
        else:
            with pytest.raises(cutsim.UsageError, match="transaction_end"):
                sim.forces()
            np.asarray(sim.x)  # the views may be read at any event (no UsageError)

    sim.on_topology_event(reader)
    sim.compact()
    sim.remove_topology_callback(reader)
    energy, forces = seen[-1]
    assert energy == pytest.approx(sim.energies()["StretchSprings"])
    np.testing.assert_array_equal(forces, sim.forces())
    assert sim.validate() == []


def test_edit_arrays_resized_in_the_block(small_scene):
    sim = cutsim.Simulation(small_scene)
    before = np.array(sim.v)
    with pytest.raises(cutsim.UsageError, match="resized or replaced"):
        with sim.edit() as e:
            e.v.resize((1, 3), refcheck=False)
    np.testing.assert_array_equal(sim.v, before)


def test_views_kept_by_controllers_make_no_leak(small_scene):
    class Keeper(cutsim.Controller):
        def __init__(self, s):
            self.view = s.view()
            self.edit = s.edit()

        def on_step_end(self, s):
            self.view.valid

    sim = cutsim.Simulation(small_scene)
    sim.add_controller(Keeper(sim))
    sim.step(2)
    view = sim.view()
    ref = weakref.ref(sim)
    del sim
    gc.collect()
    assert ref() is None
    assert not view.valid
    with pytest.raises(cutsim.StaleViewError, match="deleted"):
        view.x


def test_every_failing_action_of_a_step_is_reported(small_scene):
    sim = cutsim.Simulation(small_scene)
    for name in ("a", "b"):
        sim.act({"action": "release", "at": 0.01, "name": name})
    with pytest.raises(cutsim.Error) as e:
        sim.step(3)
    message = str(e.value)
    assert 'no grasp named "a"' in message and 'no grasp named "b"' in message, message
    assert sim.step_count == 2
    sim.step(3)  # and the run goes on
    assert sim.step_count == 5


def test_record_starts_even_when_a_callback_raises(small_scene, tmp_path):
    small_scene["timeline"] = [{"at": 0, "action": "cut", "polyline": [[0, 0.5, 0], [0.5, 0.5, 0]]}]
    sim = cutsim.Simulation(small_scene)
    sim.on_topology_event(lambda ev: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        sim.record(tmp_path / "run")
    assert (tmp_path / "run").is_dir()
    assert sim.finish_recording() is not None


def test_ids_are_integers(small_scene):
    sim = cutsim.Simulation(small_scene)
    for bad in (1.99, True, "3", np.nan):
        with pytest.raises(TypeError, match="integer"):
            sim.tear(bad)
        with pytest.raises(TypeError, match="integer"):
            sim.grasp("g", points=[bad])
    with pytest.raises(TypeError, match="integer"):
        sim.tear(points=(1.9, 10.2))


def test_odd_files_and_numbers(tmp_path, small_scene, monkeypatch):
    import json
    f = tmp_path / "bom.json"
    f.write_bytes(b"\xef\xbb\xbf" + json.dumps(small_scene).encode())
    assert cutsim.load(f).name == "small"
    g = tmp_path / "latin1.json"
    g.write_bytes(json.dumps(small_scene).replace('"small"', '"sm\xe9ll"').encode("latin-1"))
    with pytest.raises(cutsim.InvalidInputError) as e:
        cutsim.load(g)
    assert str(e.value) and "latin1.json" in str(e.value)
    small_scene["duration"] = 10 ** 400
    with pytest.raises(cutsim.InvalidInputError, match="/duration: an integer of 401 digits"):
        cutsim.Simulation(small_scene)
    small_scene["duration"] = 0.1
    sim = cutsim.Simulation(small_scene)
    with pytest.raises(TypeError, match="initialised once"):
        sim.__init__(small_scene)
    # A relative output folder is the one of the time record() was called.
    monkeypatch.chdir(tmp_path)
    sim.record("relative")
    monkeypatch.chdir("/")
    sim.run()
    sim.finish_recording()
    assert len(list((tmp_path / "relative").glob("surface_*.vtp"))) == 3


def test_a_point_is_held_by_one_constraint(small_scene):
    sim = cutsim.Simulation(small_scene)
    fixed = int(sim.fixed_points()[0])
    with pytest.raises(cutsim.Error, match=f"point {fixed} is fixed: a point is held by one constraint"):
        sim.grasp("g", points=[fixed])
    sim.grasp("g", points=[40])
    with pytest.raises(cutsim.Error, match='point 40 is held by the grasp "g"'):
        sim.grasp("h", points=[40, 41])
    with pytest.raises(cutsim.InvalidInputError, match='point 40 is held by the grasp "g"'):
        sim.fix(points=[40])
    sim.release("g")
    sim.fix(points=[40])
    assert 40 in sim.fixed_points()


def test_a_grasp_the_recording_has_no_columns_for_is_refused(small_scene, tmp_path):
    """A grasp started during a recording that was not named when it started would have no CSV
    columns: refused, saying how to name it; a named one records its forces."""
    sim = cutsim.Simulation(small_scene)
    sim.record(tmp_path / "a", grasps=["named"])
    with pytest.raises(cutsim.UsageError, match=r'no CSV columns for the grasp "late".*grasps=\["late"\]'):
        sim.grasp("late", points=[40])
    sim.grasp("named", points=[40], path=[[0, 0, 0, 0], [0.05, 0, 0, 0.01]])
    sim.step(5)
    sim.finish_recording()
    header = next(p for p in tmp_path.glob("a/steps*.csv")).read_text().splitlines()[0]
    assert "named_fx" in header and "late_fx" not in header


def test_the_module_exports_only_its_own_names():
    """No helper module (json, os, numpy) leaks into the cutsim namespace; the public methods
    have their documentation."""
    public = {n for n in dir(cutsim) if not n.startswith("_")}
    assert not public & {"json", "os", "np", "numpy"}, public
    for method in ("move", "grasp_forces", "grasp", "cut", "record"):
        doc = getattr(cutsim.Simulation, method).__doc__ or ""
        assert len(doc.split(")", 1)[-1].strip()) > 20, method


def test_a_cut_at_world_positions_says_polylines_are_rest_coordinates(small_scene):
    """A polyline given where the surface is now (not on the rest surface) is refused, saying
    that a cut's polyline is in rest coordinates."""
    sim = cutsim.Simulation(small_scene)
    far = sim.rest.max(axis=0) + 5.0
    with pytest.raises(cutsim.TopologyError, match="rest coordinates"):
        sim.cut([far.tolist(), (far + 0.1).tolist()])


def test_a_cut_beside_an_earlier_one_that_opens_nothing_says_so(small_scene):
    """A cut a millimetre beside an earlier one snaps onto its lips: it opens nothing, and says
    so (it used to return an empty incision, counted as no cut, without a word); the mesh is
    unchanged, and a cut farther away is made."""
    sim = cutsim.Simulation(small_scene)
    lo, hi = sim.rest.min(axis=0), sim.rest.max(axis=0)
    y = 0.5 * (lo[1] + hi[1])
    sim.cut([[lo[0], y, 0.0], [0.5 * (lo[0] + hi[0]), y, 0.0]])
    assert sim.cuts_done == 1
    before = (sim.num_points, sim.num_triangles)
    with pytest.raises(cutsim.TopologyError, match="opens nothing"):
        sim.cut([[lo[0], y + 1e-3, 0.0], [0.5 * (lo[0] + hi[0]), y + 1e-3, 0.0]])
    assert (sim.num_points, sim.num_triangles) == before
    assert sim.cuts_done == 1
    sim.validate()


def test_an_abandoned_or_failed_recording_is_written_as_partial(small_scene, tmp_path):
    """A recording dropped without finish_recording(), or finished right after a failed step, is
    written whole under partial names (as an interrupted `cutsim run`), never as a finished run;
    one finished after good steps is a finished run."""
    sim = cutsim.Simulation(small_scene)
    sim.record(tmp_path / "abandoned")
    sim.step(3)
    del sim
    gc.collect()
    names = {p.name for p in (tmp_path / "abandoned").iterdir()}
    assert "steps.partial.csv" in names and "steps.csv" not in names, names
    assert not any(n.endswith(".tmp") for n in names), names
    assert any(n.endswith(".partial.pvd") for n in names) and "surface.pvd" not in names, names

    small_scene.pop("linearSolver")
    small_scene["integrator"] = {"type": "explicit-euler"}
    small_scene["forceFields"][0]["stiffness"] = 1e9
    small_scene["timeStep"] = 0.05
    failing = cutsim.Simulation(small_scene)
    failing.record(tmp_path / "failed")
    with pytest.raises(cutsim.SolverError):
        failing.step(200)
    with pytest.warns(cutsim.SolverWarning, match="written as a partial run"):
        failing.finish_recording()
    names = {p.name for p in (tmp_path / "failed").iterdir()}
    assert "steps.partial.csv" in names and "steps.csv" not in names, names

    good = cutsim.Simulation(small_scene)
    good.record(tmp_path / "good")
    good.step(1)
    good.finish_recording()
    assert (tmp_path / "good" / "steps.csv").exists()


def test_a_run_beyond_the_memory_is_refused_and_a_fallback_beyond_it_warns(small_scene, monkeypatch):
    """The scene check estimates the memory a run needs: a mesh that cannot fit is refused, and a
    fallback to CHOLMOD whose factor could not fit is a RuntimeWarning (CUTSIM_MEMORY stands for
    the machine's memory)."""
    points = cutsim.Simulation(small_scene).num_points
    monkeypatch.setenv("CUTSIM_MEMORY", "1e7")
    with pytest.raises(cutsim.InvalidInputError, match=f"a mesh of {points} points needs about"):
        cutsim.Simulation(small_scene)
    # Enough for the run (16 MB and 1.28 KB a point), not for the factor (160 B 3N log2(3N)).
    run = 16e6 + 1280 * points
    monkeypatch.setenv("CUTSIM_MEMORY", repr(run + 10.0))
    with pytest.warns(RuntimeWarning, match="falls back to CHOLMOD"):
        sim = cutsim.Simulation(small_scene)
    sim.step()
    monkeypatch.setenv("CUTSIM_MEMORY", "1e12")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cutsim.Simulation(small_scene)


def test_a_solve_whose_residual_carries_the_motions_energy_is_flagged(small_scene):
    """A spring damping huge against the masses: CG meets its relative tolerance with an answer
    that makes energy from nothing. The step says so (flag residual-energy, a SolverWarning, the
    summary's count) and the fallback (CHOLMOD) solves it again: no energy beyond gravity's work."""
    small_scene["forceFields"][0]["damping"] = 1e15
    small_scene["integrator"]["rayleighMass"] = 0.0
    small_scene["linearSolver"] = {"type": "cg", "iterations": 200, "tolerance": 1e-4}
    sim = cutsim.Simulation(small_scene)
    with pytest.warns(cutsim.SolverWarning, match="residual-energy"):
        sim.step(20)
    summary = sim.solve_summary
    assert summary["residual_energy"] > 10
    assert summary["fell_back"] >= summary["residual_energy"]
    # Free fall of the whole sheet for 0.1 s bounds what gravity could have given it.
    assert sim.energies()["kinetic"] < 0.5 * 0.2 * (9.81 * 0.1) ** 2
    # The same sheet with its usual damping: nothing flagged.
    small_scene["forceFields"][0]["damping"] = 0.2
    calm = cutsim.Simulation(small_scene)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        calm.step(20)
    assert calm.solve_summary["residual_energy"] == 0
