"""World and material from Python: locate, rays and segments against a brute force over every
triangle (numpy), material points carried back to the world and to rest; a scalpel played from a
dict cuts the surface where it hangs; a cautery from a dict carves it where it hangs; forceps
from a dict take it where it hangs and carry it."""
import pathlib

import numpy as np
import pytest

import cutsim


def closest_on_triangles(q, a, b, c):
    """Closest points of every triangle (rows of a, b, c) to q: (points, distances), by sampling
    the exact region tests of Ericson written with numpy (a twin of nothing in cutsim)."""
    ab, ac, ap = b - a, c - a, q - a
    d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
    bp = q - b
    d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
    cp = q - c
    d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    out = np.empty_like(a)
    for i in range(a.shape[0]):
        if d1[i] <= 0 and d2[i] <= 0:
            out[i] = a[i]
        elif d3[i] >= 0 and d4[i] <= d3[i]:
            out[i] = b[i]
        elif d6[i] >= 0 and d5[i] <= d6[i]:
            out[i] = c[i]
        elif vc[i] <= 0 and d1[i] >= 0 and d3[i] <= 0:
            out[i] = a[i] + d1[i] / (d1[i] - d3[i]) * ab[i]
        elif vb[i] <= 0 and d2[i] >= 0 and d6[i] <= 0:
            out[i] = a[i] + d2[i] / (d2[i] - d6[i]) * ac[i]
        elif va[i] <= 0 and (d4[i] - d3[i]) >= 0 and (d5[i] - d6[i]) >= 0:
            w = (d4[i] - d3[i]) / ((d4[i] - d3[i]) + (d5[i] - d6[i]))
            out[i] = b[i] + w * (c[i] - b[i])
        else:
            den = 1.0 / (va[i] + vb[i] + vc[i])
            out[i] = a[i] + ab[i] * vb[i] * den + ac[i] * vc[i] * den
    return out, np.linalg.norm(out - q, axis=1)


def draped(small_scene):
    """The small cloth after falling a while (curved), cut once."""
    sim = cutsim.Simulation(small_scene)
    sim.cut([[0.2, 0.5, 0], [0.7, 0.45, 0]])
    sim.step(40)
    return sim


def test_locate_agrees_with_the_brute_force(small_scene):
    sim = draped(small_scene)
    x, tri = sim.x, sim.triangles()
    ids = sim.triangle_ids()
    a, b, c = x[tri[:, 0]], x[tri[:, 1]], x[tri[:, 2]]
    rng = np.random.default_rng(3)
    q = np.column_stack([rng.uniform(-0.2, 1.2, 60), rng.uniform(-0.2, 1.2, 60),
                         rng.uniform(-0.6, 0.3, 60)])
    got = sim.locate(q)
    assert got["found"].all()
    for i in range(q.shape[0]):
        _, d = closest_on_triangles(q[i], a, b, c)
        assert got["distance"][i] == pytest.approx(d.min(), abs=1e-12)
        # The point is on its triangle, from its weights, and its rest position from the same.
        k = int(np.flatnonzero(ids == got["triangle"][i])[0])
        w = got["weights"][i]
        assert w.min() >= -1e-12 and w.sum() == pytest.approx(1, abs=1e-12)
        np.testing.assert_allclose(w @ np.array([a[k], b[k], c[k]]), got["point"][i], atol=1e-12)
        r = sim.rest[tri[k]]
        np.testing.assert_allclose(w @ r, got["rest"][i], atol=1e-12)
    # Material to world and to rest, and back: a surface point locates to itself.
    np.testing.assert_allclose(sim.world_of(got["triangle"], got["weights"]), got["point"],
                               atol=1e-12)
    np.testing.assert_allclose(sim.rest_of(got["triangle"], got["weights"]), got["rest"],
                               atol=1e-12)
    again = sim.locate(got["point"])
    np.testing.assert_allclose(again["distance"], 0, atol=1e-12)
    # Nothing within a small radius of far points; one point alone is one row.
    far = sim.locate([[5, 5, 5]], max_distance=1.0)
    assert not far["found"][0] and far["triangle"][0] == -1
    assert sim.locate([0.5, 0.5, 0])["found"].shape == (1,)


def test_rays_and_segments(small_scene):
    sim = draped(small_scene)
    # Straight down onto the cloth from above: the first hit is the top of the surface there.
    origins = np.array([[0.3, 0.8, 1.0], [0.6, 0.9, 1.0], [3.0, 3.0, 1.0]])
    hits = sim.ray_hits(origins, [0, 0, -1])
    assert hits["found"].tolist() == [True, True, False]
    for i in range(2):
        seg = sim.segment_hits(origins[i], origins[i] - [0, 0, 3])
        assert seg["t"].size >= 1
        assert np.all(np.diff(seg["t"]) >= 0)
        assert hits["t"][i] == pytest.approx(3 * seg["t"][0], abs=1e-12)
        np.testing.assert_allclose(hits["point"][i], seg["point"][0], atol=1e-12)
    with pytest.raises(ValueError, match="direction 0 is zero"):
        sim.ray_hits([[0, 0, 0]], [[0, 0, 0]])
    with pytest.raises(ValueError, match="triangle 100000"):
        sim.world_of([100000], [[1, 0, 0]])
    with pytest.raises(ValueError, match="non-finite"):
        sim.locate([[np.nan, 0, 0]])


def test_a_scalpel_from_a_dict_cuts_where_the_cloth_hangs(small_scene):
    # The cloth falls from its two top corners; a blade crossing the hanging cloth horizontally
    # at a height it has there (found with locate, in world space) cuts it along that height.
    small_scene["duration"] = 1.0
    sim = cutsim.Simulation(small_scene)
    sim.step(60)
    mid = sim.locate([[0.5, 0.7, -1.0]])
    z = mid["point"][0][2]
    y = mid["point"][0][1]
    sim.act({"action": "scalpel", "from": sim.time, "to": sim.time + 0.1, "depth": 0.2,
             "path": [[0, -0.2, y - 0.1, z, 0, 1, 0], [0.1, 1.2, y - 0.1, z, 0, 1, 0]]})
    made = []
    for _ in range(20):
        before = sim.alive.copy()
        sim.step()
        alive = sim.alive
        new = np.flatnonzero(alive[: before.size] & ~before).tolist() + list(range(before.size, alive.size))
        made += [sim.x[i][2] - z for i in new if alive[i]]
        assert not sim.validate()
    assert len(made) > 5  # it cut
    # Where the cloth was when it was cut: at the blade's height (the repair moves a few points
    # around the incision by a fraction of an edge, 0.125 here).
    assert np.median(np.abs(made)) < 1e-6
    assert np.max(np.abs(made)) < 0.05


def test_a_cautery_from_a_dict_carves_where_the_cloth_hangs(small_scene):
    # A ball run across the hanging cloth at a point found with locate: nothing of the cloth is
    # left within its radius of its path, in the world, and the hole's rim is on that boundary.
    small_scene["duration"] = 1.0
    sim = cutsim.Simulation(small_scene)
    sim.step(60)
    mid = sim.locate([[0.5, 0.7, -1.0]])["point"][0]
    a, b, r = mid + [-0.2, 0, 0], mid + [0.2, 0, 0], 0.15
    sim.act({"action": "cautery", "from": sim.time, "to": sim.time + 0.05, "radius": r,
             "path": [[0, *a], [0.05, *b]]})
    def rest_area():
        t = sim.rest[sim.triangles()]
        return 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1).sum()

    area = rest_area()
    sim.step()  # (the cloth moves on: what it carves is where the cloth is when it carves)
    for _ in range(10):
        sim.step()
        assert not sim.validate()
    # The area gone is at most the ball's trace on a flat cloth through its path (a stadium 2 r
    # wide, 0.4 + 2 r long), less where the hanging cloth curves away from the path (60% here).
    stadium = 0.4 * 2 * r + np.pi * r * r
    assert 0.4 * stadium < area - rest_area() < stadium
    # (the last pass carved where the ball swept since the one before: check the whole path
    # against the cloth as it is would need the cloth to hold still; it holds nearly still over
    # the last steps, and nothing lies deeper inside than it moved)
    ab = b - a
    x = sim.x[sim.alive]
    t = np.clip(((x - a) @ ab) / (ab @ ab), 0, 1)
    depth = r - np.linalg.norm(x - (a + t[:, None] * ab), axis=1)
    assert depth.max() < 0.02


def test_forceps_from_a_dict_take_the_cloth_where_it_hangs_and_carry_it(small_scene):
    # Jaws closing around a point of the hanging cloth found with locate take that material
    # point (inserted into the mesh) and carry it 10 cm up; their force is a grasp's.
    small_scene["duration"] = 1.0
    sim = cutsim.Simulation(small_scene)
    sim.step(60)
    hit = sim.locate([[0.43, 0.61, -1.0]])
    p = hit["point"][0]
    t0 = sim.time
    sim.act({"action": "forceps", "name": "jaws", "from": t0, "to": t0 + 0.2,
             "axis": [0, 0, 1], "across": [1, 0, 0], "radius": 0.01, "length": 0.2,
             "path": [[0, p[0], p[1], p[2] - 0.1, 0.05], [0.01, p[0], p[1], p[2] - 0.1, 0.02],
                      [0.2, p[0], p[1], p[2] + 0.0, 0.02]]})
    n = sim.alive.size
    sim.step(3)
    assert "jaws" in sim.grasp_forces()
    assert sim.alive.size > n  # the material point was inserted
    # The point taken is on the jaws' middle line (they move along z only).
    new = [i for i in range(n, sim.alive.size) if sim.alive[i]]
    taken = [i for i in new if np.linalg.norm(sim.x[i][:2] - p[:2]) < 1e-9]
    assert len(taken) == 1

    def z_of_jaws(t):
        return p[2] - 0.1 + 0.1 * np.clip((t - t0 - 0.01) / 0.19, 0, 1)

    start, t1 = sim.x[taken[0]].copy(), sim.time
    sim.step(40)  # to t0 + 0.2 and on: the jaws hold where they stopped
    moved = sim.x[taken[0]] - start
    np.testing.assert_allclose(moved, [0, 0, z_of_jaws(sim.time) - z_of_jaws(t1)], atol=1e-9)
    assert moved[2] > 0.05
    assert not sim.validate()


def test_bad_scalpel_paths_are_refused(small_scene):
    sim = cutsim.Simulation(small_scene)
    entry = {"action": "scalpel", "from": 0, "to": 0.1, "depth": 0.1,
             "path": [[0, 0, 0.5, 0, 0, 0, 1], [0.1, float("nan"), 0.5, 0, 0, 0, 1]]}
    with pytest.raises(cutsim.InvalidInputError, match="path/1/1"):
        sim.act(entry)
    entry["path"] = [[0, 0, 0.5, 0, 0, 0, 1], [0.1, 1, 0.5, 0, 0, 0, 0]]
    with pytest.raises(cutsim.InvalidInputError, match="axis"):
        sim.act(entry)
    entry["path"] = [[0, 0, 0.5, 0, 0, 0, 1]]
    entry["depth"] = 0
    with pytest.raises(cutsim.InvalidInputError, match="depth"):
        sim.act(entry)


def test_the_blade_is_drawn_in_the_frames_and_the_player(small_scene, tmp_path):
    import re
    small_scene["duration"] = 0.3
    small_scene["output"] = {"every": 4}
    sim = cutsim.Simulation(small_scene)
    run = tmp_path / "run"
    sim.record(run)
    tip0, tip1 = np.array([-0.2, 0.5, -0.3]), np.array([1.2, 0.5, -0.3])
    sim.act({"action": "scalpel", "from": 0.05, "to": 0.15, "depth": 0.6,
             "path": [[0, *tip0, 0, 0, 1], [0.1, *tip1, 0, 0, 1]]})
    sim.run()
    sim.finish_recording()
    frames = re.findall(r'timestep="([^"]+)"[^>]*file="([^"]+)"', (run / "instruments.pvd").read_text())
    assert frames, "no instruments series"
    drawn = 0
    for t, name in frames:
        t = float(t)
        text = (run / name).read_text()
        points = re.search(r'Name="position"[^>]*>([^<]*)<', text).group(1).split()
        if not 0.05 - 1e-9 <= t <= 0.15 + 1e-9:
            assert points == [], f"a blade drawn at t = {t}, outside its interval"
            continue
        drawn += 1
        p = np.array(points, dtype=float).reshape(-1, 3)
        expected = tip0 + (tip1 - tip0) * (t - 0.05) / 0.1
        np.testing.assert_allclose(p[0], expected, atol=1e-12)
        np.testing.assert_allclose(p[1], expected + [0, 0, 0.6], atol=1e-12)
    assert drawn >= 3
    page = cutsim.write_player(run)
    assert "instrumentX" in pathlib.Path(page["path"]).read_text()


def border_edges(triangles):
    """How many edges of the triangles (rows of point indices) belong to one triangle only."""
    e = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]),
                axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return int((counts == 1).sum())


def test_a_sew_from_a_dict_joins_the_lips_where_they_meet(small_scene):
    # Cut the hanging cloth, let it hang a few steps (the lips stay together where nothing pulls
    # them apart), then sew: the border is the cloth's outline again.
    small_scene["duration"] = 1.0
    sim = cutsim.Simulation(small_scene)
    sim.step(20)
    outline = border_edges(sim.triangles())
    sim.cut([[0.3, 0.5, 0], [0.7, 0.5, 0]])
    sim.step(2)
    assert border_edges(sim.triangles()) > outline
    with pytest.raises(Exception, match="no lips lie within the tolerance 1e-12"):
        sim.act({"action": "sew", "at": sim.time, "tolerance": 1e-12, "minAngle": 0})
        sim.step()
    sim.act({"action": "sew", "at": sim.time, "tolerance": 0.02})
    sim.step()
    assert border_edges(sim.triangles()) == outline
    assert not sim.validate()
    assert np.isfinite(sim.x[sim.alive]).all()
