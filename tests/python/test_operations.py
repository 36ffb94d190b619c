"""Topology operations, grasps, constraints and actions from Python."""
import numpy as np
import pytest

import cutsim


def test_rejected_cut_changes_nothing(small_scene):
    sim = cutsim.Simulation(small_scene)
    sim.step(3)
    before = (np.array(sim.x), sim.triangles(), sim.revision)
    events = []
    sim.on_topology_event(events.append)
    with pytest.raises(cutsim.TopologyError) as e:
        sim.cut([[5.0, 5.0, 0.0], [6.0, 5.0, 0.0]])  # off the surface
    assert isinstance(e.value, ValueError) and str(e.value)
    np.testing.assert_array_equal(sim.x, before[0])
    np.testing.assert_array_equal(sim.triangles(), before[1])
    assert sim.revision == before[2] and events == []
    with pytest.raises(ValueError, match="at least two points"):
        sim.cut([[0.5, 0.5, 0.0]])
    with pytest.raises(ValueError, match="non-finite"):
        sim.cut([[0.5, 0.5, 0.0], [np.inf, 0.5, 0.0]])


def test_cut_result(small_scene):
    sim = cutsim.Simulation(small_scene)
    r = sim.cut([[0.0, 0.5, 0.0], [0.6, 0.5, 0.0]], min_angle=20)
    assert len(r["path"]) >= 2 and len(r["copies"]) == len(r["copied_from"]) > 0
    assert r["min_angle_after"] >= 20 - 1e-9 or r["min_angle_after"] >= r["min_angle_before"]
    np.testing.assert_allclose(sim.rest[r["copies"]], sim.rest[r["copied_from"]], atol=1e-15)


def test_grasp_move_release(small_scene):
    small_scene["constraints"] = []
    small_scene["gravity"] = [0, 0, 0]
    sim = cutsim.Simulation(small_scene)
    sim.grasp("forceps", near=[[0.5, 1.0, 0.0]])
    p = int(sim.grasp_points("forceps")[0])
    sim.move("forceps", [0, 0, 0.05], duration=0.05)
    sim.step(10)  # 0.05 s: the move is done
    assert sim.x[p, 2] == pytest.approx(0.05, abs=1e-12)
    force = sim.grasp_forces()["forceps"]
    assert force.shape == (3,) and force[2] > 0  # pulling the cloth up
    sim.step(5)
    assert sim.x[p, 2] == pytest.approx(0.05, abs=1e-12)  # held there
    sim.release("forceps")
    assert "forceps" not in sim.grasp_forces()
    with pytest.raises(cutsim.InvalidInputError, match="no grasp named"):
        sim.move("forceps", [0, 0, 1])
    with pytest.raises(cutsim.InvalidInputError, match="no grasp named"):
        sim.release("forceps")
    sim.step(5)
    assert sim.x[p, 2] != pytest.approx(0.05, abs=1e-9)


def test_grasp_with_a_path_and_duplicate_names(small_scene):
    sim = cutsim.Simulation(small_scene)
    sim.step(2)
    sim.grasp("g", box=[[0.3, 0.0, -1], [0.7, 0.1, 1]], path=[[0, 0, 0, 0], [0.05, 0, 0.1, 0]])
    assert len(sim.grasp_points("g")) >= 2
    with pytest.raises(cutsim.Error, match="g"):
        sim.grasp("g", points=[0])


def test_fix_and_unfix(small_scene):
    small_scene["constraints"] = []
    sim = cutsim.Simulation(small_scene)
    sim.fix(near=[[0, 1, 0], [1, 1, 0]])
    fixed = sim.fixed_points()
    assert len(fixed) == 2
    sim.step(10)
    np.testing.assert_array_equal(sim.x[fixed], sim.rest[fixed])
    sim.unfix(fixed[:1])
    assert list(sim.fixed_points()) == [fixed[1]]
    sim.step(5)
    assert sim.x[fixed[0], 2] < 0
    with pytest.raises(cutsim.InvalidInputError, match=r"<fix>:\d+: /: give exactly one of"):
        sim._constrain('{"type": "fixed"}', "<fix>")
    with pytest.raises(TypeError, match="exactly one of"):
        sim.fix(points=[1], box=[[0, 0, 0], [1, 1, 1]])


def test_actions_from_dicts(small_scene):
    sim = cutsim.Simulation(small_scene)
    with pytest.raises(cutsim.InvalidInputError, match=r"<action tearing>:\d+: /threshold: "):
        sim.act({"action": "tearing", "threshold": -1})
    with pytest.raises(cutsim.InvalidInputError, match=r"/action: unknown action \"slice\""):
        sim.act({"action": "slice"})
    sim.step(4)
    with pytest.raises(cutsim.InvalidInputError, match="before the current time"):
        sim.act({"action": "cut", "at": 0.0, "polyline": [[0, 0.5, 0], [0.5, 0.5, 0]]})
    # A progressive cut, scheduled ahead: it runs while the steps go.
    sim.act({"action": "cut", "from": 0.03, "to": 0.06, "polyline": [[0, 0.5, 0], [0.6, 0.5, 0]]})
    points = sim.num_points
    sim.step(4)
    assert sim.num_points > points
    sim.run_until(0.08)
    assert sim.cuts_done >= 2 and sim.validate() == []
    # A cut that fails when it meets the surface names its source.
    with pytest.raises(cutsim.Error, match=r"<action cut>:\d+: /: at t = .*the cut failed"):
        sim.act({"action": "cut", "polyline": [[5, 5, 0], [6, 5, 0]]})
    assert sim.validate() == []


def test_remove_and_parameters_between_steps(small_scene):
    sim = cutsim.Simulation(small_scene)
    sim.step(5)
    n = sim.num_triangles
    sim.remove(box=([0.3, 0.3, -1], [0.6, 0.6, 1]))
    assert sim.num_triangles < n
    sim.gravity = [0, 0, -20]
    np.testing.assert_array_equal(sim.gravity, [0, 0, -20])
    z = sim.x[:, 2].min()
    sim.step(5)
    assert sim.x[:, 2].min() < z
    with pytest.raises(ValueError, match="non-finite"):
        sim.gravity = [0, 0, np.nan]


def test_set_parameters_between_steps(small_scene):
    sim = cutsim.Simulation(small_scene)
    sim.step(20)
    x = np.array(sim.x)
    e0, f0 = sim.eval_bending(x)
    sim.set_parameters("FastTriangularBendingSprings", bendingStiffness=0.004)
    e1, f1 = sim.eval_bending(x)
    assert e1 == pytest.approx(2 * e0, rel=1e-12)
    np.testing.assert_allclose(f1, 2 * f0, rtol=1e-12, atol=1e-15)
    assert sim.parameters("FastTriangularBendingSprings")["bendingStiffness"] == 0.004
    # Prestrain: rest lengths 0.9 of the mesh's stretch the cloth at its rest positions.
    assert sim.eval("StretchSprings", sim.rest)[0] == pytest.approx(0, abs=1e-20)
    sim.set_parameters("StretchSprings", {"restScale": 0.9})
    assert sim.eval("StretchSprings", sim.rest)[0] > 0
    # The new fields follow the topology like the old ones.
    sim.cut([[0.0, 0.5, 0.0], [0.6, 0.5, 0.0]])
    assert sim.validate() == []
    sim.step(5)
    with pytest.raises(cutsim.InvalidInputError, match=r"<set_parameters StretchSprings>:\d+: /stiffness: "):
        sim.set_parameters("StretchSprings", stiffness=-5)
    with pytest.raises(cutsim.InvalidInputError, match="can change, not its type"):
        sim.set_parameters("StretchSprings", type="FastTriangularBendingSprings", bendingStiffness=1)
    with pytest.raises(cutsim.InvalidInputError, match="no force field labelled"):
        sim.set_parameters("Nope", stiffness=1)
    assert sim.parameters("StretchSprings")["restScale"] == 0.9


def test_contact_figures(source_dir):
    import json
    scene = json.loads((source_dir / "data/scenes/fold_ground.json").read_text())
    scene["mesh"]["grid"].update(nx=12, ny=12)
    sim = cutsim.Simulation(scene, base_dir=source_dir / "data/scenes")
    assert sim.contact()["thickness"] == scene["contact"]["thickness"]
    sim.run_until(0.3)
    c = sim.contact()
    assert [o["name"] for o in c["obstacles"]] == [o.get("name", f"{o['type']}0") for o in scene["obstacles"]]
    assert c["candidates"] >= c["active"] > 0
    assert sum(c["obstacle_normal_force"].values()) > 0
    assert sim.intersections() == []
    without = {k: v for k, v in scene.items() if k not in ("contact", "obstacles")}
    small = cutsim.Simulation(without, base_dir=source_dir / "data/scenes")
    assert small.contact() is None
    with pytest.raises(cutsim.InvalidInputError, match="no contact"):
        small.intersections()


def test_move_an_obstacle(source_dir):
    scene = {
        "mesh": {"grid": {"nx": 9, "ny": 9, "size": [0.4, 0.4], "origin": [-0.2, -0.2, 0.01]}},
        "mass": {"total": 0.05}, "gravity": [0, 0, -9.81],
        "forceFields": [{"type": "StretchSprings", "stiffness": 200, "damping": 0.1},
                        {"type": "FastTriangularBendingSprings", "bendingStiffness": 0.001}],
        "contact": {"thickness": 0.005, "stiffness": 0.5, "friction": 0.2},
        "obstacles": [{"type": "plane", "name": "table", "point": [0, 0, 0], "normal": [0, 0, 1]}],
        "integrator": {"type": "implicit-euler", "rayleighMass": 1.0},
        "linearSolver": {"type": "cg", "iterations": 300, "tolerance": 1e-6},
        "timeStep": 0.005, "duration": 1,
    }
    sim = cutsim.Simulation(scene)
    sim.run_until(0.2)
    sim.move_obstacle("table", [0, 0, 0.05], duration=0.25)  # the table rises 5 cm
    sim.run_until(0.6)
    table = sim.contact()["obstacles"][0]
    np.testing.assert_allclose(table["offset"], [0, 0, 0.05], atol=1e-12)
    z = sim.x[sim.alive][:, 2]
    assert z.min() > 0.05  # carried up, never through
    assert sim.intersections() == []
    with pytest.raises(cutsim.InvalidInputError, match="duration > 0"):
        sim.move_obstacle("table", [0, 0, 1], duration=0)
    with pytest.raises(cutsim.InvalidInputError, match='no obstacle named "chair"'):
        sim.move_obstacle("chair", [0, 0, 1], duration=1)


def test_sofa_style_controllers_and_misspelt_ones(small_scene):
    sim = cutsim.Simulation(small_scene)
    seen = []

    class Sofa:
        def onAnimateBeginEvent(self, event):
            seen.append(("begin", event["time"], event["dt"], event["sim"] is sim))

        def onAnimateEndEvent(self, event):
            seen.append(("end", event["time"]))

    sim.add_controller(Sofa())
    sim.step(2)
    assert seen == [("begin", 0.0, 0.005, True), ("end", 0.005), ("begin", 0.005, 0.005, True), ("end", 0.01)]

    class Misspelt(cutsim.Controller):
        def on_step_ende(self, s):
            pass

    with pytest.raises(TypeError, match="overrides none of"):
        sim.add_controller(Misspelt())


def test_operations_say_what_they_did_and_why_they_did_not(small_scene, tmp_path):
    sim = cutsim.Simulation(small_scene)
    assert sim.remove(box=([0.3, 0.3, -1], [0.6, 0.6, 1])) > 0
    with pytest.raises(cutsim.InvalidInputError, match="removes no triangle"):
        sim.remove(sphere=([5, 5, 0], 0.1))
    with pytest.raises(cutsim.InvalidInputError, match="point 1000000 is not a point of the surface"):
        sim.grasp("g", points=[10 ** 6])
    with pytest.raises(cutsim.TopologyError, match="the cut failed"):
        sim.act({"action": "cut", "polyline": [[5, 5, 0], [6, 5, 0]]})
    with pytest.raises(cutsim.InvalidInputError, match="point 40 is not fixed"):
        sim.unfix([40])
    # A grasp active when the recording starts has its CSV columns.
    sim.grasp("forceps", points=[10])
    sim.record(tmp_path)
    sim.step(2)
    sim.finish_recording()
    header = (tmp_path / "steps.csv").read_text().splitlines()[0]
    assert header.endswith("forceps_fx,forceps_fy,forceps_fz")


def test_grasp_a_world_sphere_and_one_side_of_a_cut(small_scene):
    small_scene["constraints"] = []
    small_scene["gravity"] = [0, 0, 0]
    sim = cutsim.Simulation(small_scene)
    sim.cut([[0.0, 0.45, 0.0], [1.0, 0.45, 0.0]])
    alive = np.asarray(sim.view().alive, dtype=bool)
    with sim.edit() as e:  # the whole sheet moved up by 1: rest coordinates no longer say where it is
        e.x[alive, 2] += 1.0
    sim.grasp("jaws", sphere=([0.5, 0.5, 1.0], 0.2))
    taken = np.asarray(sim.grasp_points("jaws"), dtype=int)
    assert taken.size > 0
    assert np.all(np.linalg.norm(sim.x[taken] - [0.5, 0.5, 1.0], axis=1) <= 0.2 + 1e-12)
    assert np.all(sim.rest[taken, 1] >= 0.45 - 1e-12)  # one side of the cut: the centre's
    sim.release("jaws")
    sim.grasp("both", sphere=([0.5, 0.5, 1.0], 0.2), piece="all")
    assert np.any(sim.rest[np.asarray(sim.grasp_points("both"), dtype=int), 1] < 0.45)
    with pytest.raises(cutsim.InvalidInputError, match="none lies within"):
        sim.grasp("air", sphere=([0.5, 0.5, 0.0], 0.2))
