"""Zero-copy views of the state, stale views, and edits."""
import numpy as np
import pytest

import cutsim

CUT = [[0.0, 0.5, 0.0], [0.6, 0.5, 0.0]]


def address(a):
    return a.__array_interface__["data"][0]


def test_views_share_memory_across_steps(small_scene):
    sim = cutsim.Simulation(small_scene)
    x, v, rest = sim.x, sim.v, sim.rest
    before = np.array(x)
    sim.step(5)
    # The same memory, updated by the steps: no copy was made, none is needed.
    assert address(x) == address(sim.x) and address(v) == address(sim.v)
    assert not np.array_equal(before, x)
    np.testing.assert_array_equal(x, sim.x)
    assert np.abs(v).max() > 0
    np.testing.assert_array_equal(rest[:, 2], 0.0)  # the grid's rest plane
    assert not x.flags.owndata


def test_views_are_read_only(small_scene):
    sim = cutsim.Simulation(small_scene)
    for a in (sim.x, sim.v, sim.rest, sim.view().x):
        assert not a.flags.writeable
        with pytest.raises(ValueError):
            a[0, 0] = 1.0


def test_stale_view_raises_after_a_cut(small_scene):
    sim = cutsim.Simulation(small_scene)
    sim.step(2)
    view = sim.view()
    old_x = view.x
    snapshot = np.array(old_x)
    assert view.valid
    sim.cut(CUT)
    assert not view.valid
    for name in ("x", "v", "rest", "alive", "triangles"):
        with pytest.raises(cutsim.StaleViewError, match="topology has changed"):
            getattr(view, name)
    # An array handed out before keeps its memory alive. Cut until the state has moved to a
    # larger buffer; from then on the old one is left as it was, and stays allocated: memory
    # freed and reused would not keep its values.
    k = 0
    while address(sim.x) == address(old_x):
        k += 1
        assert k < 40, "the state never moved to a new buffer"
        y = 0.05 + 0.02 * k
        sim.cut([[0.0, y, 0.0], [0.4 + 0.01 * k, y + 0.01, 0.0]], min_angle=0)
    left = np.array(old_x)
    garbage = [np.full(old_x.size * (1 + i % 3), 7.0) for i in range(200)]
    for i in range(3):
        y = 0.06 + 0.02 * (k + i + 1)
        sim.cut([[0.5, y, 0.0], [0.95, y + 0.01, 0.0]], min_angle=0)
    np.testing.assert_array_equal(old_x, left)
    del garbage
    fresh = sim.view()
    assert fresh.x.shape[0] == sim.num_slots > snapshot.shape[0]
    assert fresh.alive.sum() == sim.num_points


def test_stepping_does_not_make_a_view_stale(small_scene):
    sim = cutsim.Simulation(small_scene)
    view = sim.view()
    sim.step(3)
    np.testing.assert_array_equal(view.x, sim.x)


def test_edit_writes_positions_and_velocities(small_scene):
    sim = cutsim.Simulation(small_scene)
    p = int(np.flatnonzero(sim.alive)[40])
    with sim.edit() as e:
        assert e.x.flags.writeable and address(e.x) != address(sim.x)  # a copy, written back at the end
        e.x[p] += [0, 0, 0.01]
        e.v[p] = [0, 0, 1.0]
        assert sim.x[p, 2] == 0.0
        kept_x = e.x
        escaped = e.x[:]  # a view of the copy: it cannot reach the state
    assert sim.x[p, 2] == pytest.approx(0.01)
    escaped[p, 2] = np.nan
    assert np.isfinite(sim.x).all()
    assert sim.v[p, 2] == 1.0
    assert not kept_x.flags.writeable  # the edit's arrays are read-only after the block
    sim.step(1)
    assert np.isfinite(sim.x).all()


def test_edit_undone_on_error(small_scene):
    sim = cutsim.Simulation(small_scene)
    before = np.array(sim.x)
    with pytest.raises(RuntimeError, match="boom"):
        with sim.edit() as e:
            e.x[:] += 1.0
            raise RuntimeError("boom")
    np.testing.assert_array_equal(sim.x, before)
    with pytest.raises(cutsim.InvalidInputError, match=r"x\[3, 1\]: non-finite value; nothing of the edit was written"):
        with sim.edit() as e:
            e.x[0] += 1.0
            e.x[3, 1] = np.nan
    np.testing.assert_array_equal(sim.x, before)


def test_edit_block_entered_once(small_scene):
    sim = cutsim.Simulation(small_scene)
    e = sim.edit()
    e.__enter__()
    e.__exit__(None, None, None)
    before = np.array(sim.x)
    assert e.__exit__(RuntimeError, None, None) is False  # a stray exit does nothing
    with pytest.raises(cutsim.UsageError, match="entered once"):
        e.__enter__()
    with sim.edit() as other:
        other.x[0] += 1
        e.__exit__(None, None, None)  # not this block: the other edit stays open
        with pytest.raises(cutsim.UsageError):
            sim.step()
    np.testing.assert_array_equal(sim.x[0], before[0] + 1)


def test_edit_refuses_dead_slots_and_topology_changes(small_scene):
    sim = cutsim.Simulation(small_scene)
    sim.remove(sphere=([0.5, 0.5, 0], 0.2))
    dead = int(np.flatnonzero(~sim.alive)[0])
    with pytest.raises(cutsim.InvalidInputError, match=f"x\\[{dead}, 0\\]: the slot is dead"):
        with sim.edit() as e:
            e.x[dead, 0] = 1.0
    with sim.edit():
        with pytest.raises(cutsim.UsageError, match="edit"):
            sim.cut(CUT)
        with pytest.raises(cutsim.UsageError):
            sim.step()


def test_triangles_and_surface(small_scene):
    sim = cutsim.Simulation(small_scene)
    tri = sim.triangles()
    assert tri.shape == (sim.num_triangles, 3) and tri.dtype == np.int64
    sim.cut(CUT)
    points, triangles, slots = sim.surface()
    assert points.shape == (sim.num_points, 3) and triangles.max() == sim.num_points - 1
    np.testing.assert_array_equal(points, sim.x[slots])
    np.testing.assert_array_equal(slots[triangles], sim.triangles())
