"""Topology events from Python: a mirror of the mesh kept from the events alone must equal the
mesh after every operation (so the callbacks get every event, complete and in order)."""
import numpy as np
import pytest

import cutsim


class Mirror:
    """Points (with rest positions), edges and triangles, kept from the events only."""

    def __init__(self, sim):
        self.points = {int(p): np.array(sim.rest[p]) for p in np.flatnonzero(sim.alive)}
        self.edges = {int(e): (int(a), int(b)) for e, (a, b) in zip(sim.edge_ids(), sim.edges())}
        self.triangles = {int(t): tuple(map(int, v)) for t, v in zip(sim.triangle_ids(), sim.triangles())}
        self.events = []
        self.transactions = []
        self.pending = dict(points_created=0, points_destroyed=0, edges_created=0, edges_destroyed=0,
                            triangles_created=0, triangles_destroyed=0)
        self.order = []

    def __call__(self, ev):
        self.events.append(ev.kind)
        self.order.append(ev.kind)
        if ev.kind == "triangles_destroyed":
            for t, v in zip(ev.ids, ev.vertices):
                assert self.triangles.pop(int(t)) == tuple(map(int, v))
        elif ev.kind == "edges_destroyed":
            for e, v in zip(ev.ids, ev.vertices):
                assert self.edges.pop(int(e)) == tuple(map(int, v))
        elif ev.kind == "points_destroyed":
            self.destroyed_rest = {int(p): self.points[int(p)] for p in ev.ids}
            for p in ev.ids:
                del self.points[int(p)]
        elif ev.kind == "points_created":
            for i, p in enumerate(ev.ids):
                lo, hi = ev.offsets[i], ev.offsets[i + 1]
                assert hi > lo, "points made by operations have ancestors"
                assert sum(ev.weights[lo:hi]) == pytest.approx(1.0)
                ancestors = [int(a) for a in ev.ancestors[lo:hi]]
                known = {**getattr(self, "destroyed_rest", {}), **self.points}
                interpolated = sum(w * known[a] for w, a in zip(ev.weights[lo:hi], ancestors))
                self.points[int(p)] = interpolated
        elif ev.kind == "edges_created":
            for e, v in zip(ev.ids, ev.vertices):
                assert int(e) not in self.edges
                self.edges[int(e)] = tuple(map(int, v))
        elif ev.kind == "triangles_created":
            for t, v in zip(ev.ids, ev.vertices):
                assert int(t) not in self.triangles
                self.triangles[int(t)] = tuple(map(int, v))
        elif ev.kind.endswith("_renumbered"):
            table = {"points_renumbered": self.points, "edges_renumbered": self.edges,
                     "triangles_renumbered": self.triangles}[ev.kind]
            moved = {int(ev.old_to_new[k]): val for k, val in table.items()}
            assert -1 not in moved and len(moved) == ev.new_size
            table.clear()
            table.update(moved)
            if ev.kind == "points_renumbered":
                remap = lambda p: int(ev.old_to_new[p])  # noqa: E731
                self.edges = {e: tuple(map(remap, v)) for e, v in self.edges.items()}
                self.triangles = {t: tuple(map(remap, v)) for t, v in self.triangles.items()}
        elif ev.kind == "transaction_end":
            self.transactions.append(ev.operation)
            self.destroyed_rest = {}
        if ev.kind in self.pending:
            self.pending[ev.kind] += len(ev.ids)
        if ev.kind == "transaction_end":
            assert ev.summary == {**self.pending, "renumbered": any(k.endswith("renumbered") for k in self.order)}
            self.pending = {k: 0 for k in self.pending}
            self.order = []

    def check(self, sim):
        alive = set(int(p) for p in np.flatnonzero(sim.alive))
        assert set(self.points) == alive
        rest = sim.rest
        for p, r in self.points.items():
            np.testing.assert_allclose(r, rest[p], rtol=0, atol=1e-12)
        assert self.triangles == {int(t): tuple(map(int, v)) for t, v in zip(sim.triangle_ids(), sim.triangles())}
        assert self.edges == {int(e): tuple(map(int, v)) for e, v in zip(sim.edge_ids(), sim.edges())}
        assert sim.validate() == []


def test_mirror_follows_every_operation(small_scene):
    small_scene["timeline"] = [{"at": 0.05, "action": "tearing", "threshold": 0.02, "maxPerStep": 2}]
    sim = cutsim.Simulation(small_scene)
    mirror = Mirror(sim)
    sim.on_topology_event(mirror)
    sim.cut([[0.0, 0.5, 0.0], [0.6, 0.5, 0.0]])
    assert mirror.transactions[-1] and mirror.events[0] == "triangles_destroyed"
    mirror.check(sim)
    sim.remove(sphere=([0.75, 0.25, 0.0], 0.12))
    mirror.check(sim)
    torn = False
    for a, b in sim.edges():
        mid = (sim.rest[a] + sim.rest[b]) / 2
        if abs(mid[0] - 0.3) < 0.1 and abs(mid[1] - 0.8) < 0.1:
            try:
                sim.tear(points=(a, b))
                torn = True
                break
            except cutsim.TopologyError:
                continue
    assert torn
    mirror.check(sim)
    sim.compact()
    assert mirror.transactions[-1] == "compact"
    mirror.check(sim)
    # Tearing while stepping: events arrive from the step (the GIL released, taken back for them).
    with sim.edit() as e:
        e.v[:] = 0
    sim.gravity = [0, 0, -200.0]
    n = len(mirror.transactions)
    sim.step(40)
    mirror.check(sim)
    assert sim.torn_edges > 0 and len(mirror.transactions) > n


def test_event_order_within_a_transaction(small_scene):
    sim = cutsim.Simulation(small_scene)
    kinds = []
    sim.on_topology_event(lambda ev: kinds.append(ev.kind))
    sim.cut([[0.0, 0.5, 0.0], [0.6, 0.5, 0.0]])
    order = ["triangles_destroyed", "edges_destroyed", "points_destroyed", "points_created",
             "edges_created", "triangles_created", "transaction_end"]
    assert kinds == sorted(kinds, key=order.index) and kinds[-1] == "transaction_end"


def test_callbacks_may_read_but_not_change(small_scene):
    sim = cutsim.Simulation(small_scene)
    seen = []

    def reader(ev):
        seen.append((ev.kind, sim.num_triangles, float(sim.x[0, 0])))

    def changer(ev):
        if ev.kind == "transaction_end":
            sim.cut([[0.0, 0.3, 0.0], [0.5, 0.3, 0.0]])

    sim.on_topology_event(reader)
    sim.on_topology_event(changer)
    points_before = sim.num_points
    with pytest.raises(cutsim.UsageError, match="event callback may read"):
        sim.cut([[0.0, 0.5, 0.0], [0.6, 0.5, 0.0]])
    # The operation itself went through whole; the refused change did nothing.
    assert sim.num_points > points_before and sim.validate() == []
    assert all(n == sim.num_triangles for _, n, _ in seen)
    sim.remove_topology_callback(changer)
    sim.cut([[0.0, 0.3, 0.0], [0.5, 0.3, 0.0]])
    assert sim.validate() == []


def test_callback_errors_raise_after_the_operation(small_scene):
    sim = cutsim.Simulation(small_scene)

    def broken(ev):
        raise KeyError("from the callback")

    sim.on_topology_event(broken)
    with pytest.raises(KeyError, match="from the callback"):
        sim.cut([[0.0, 0.5, 0.0], [0.6, 0.5, 0.0]])
    assert sim.validate() == []
    sim.remove_topology_callback(broken)
    sim.step(2)


def test_step_controllers(small_scene):
    sim = cutsim.Simulation(small_scene)
    calls = []

    class Recorder(cutsim.Controller):
        def on_step_begin(self, s):
            assert s is sim
            calls.append(("begin", s.step_count))

        def on_step_end(self, s):
            calls.append(("end", s.step_count))
            if s.step_count == 3:
                s.cut([[0.0, 0.5, 0.0], [0.6, 0.5, 0.0]])  # controllers may change the scene

    sim.add_controller(Recorder())
    sim.step(4)
    assert calls == [("begin", 0), ("end", 1), ("begin", 1), ("end", 2), ("begin", 2), ("end", 3),
                     ("begin", 3), ("end", 4)]
    assert sim.cuts_done == 1 and sim.validate() == []  # the script's cut is an action, counted


def test_no_reentrant_step(small_scene):
    sim = cutsim.Simulation(small_scene)

    class Nested(cutsim.Controller):
        def on_step_end(self, s):
            s.step()

    sim.add_controller(Nested())
    with pytest.raises(cutsim.UsageError, match="step"):
        sim.step()


def as_line(ev):
    """The event as the module's C++ event log writes it (an observer of its own, in C++)."""
    def j(a):
        return ",".join(str(int(v)) for v in a)

    def rows(r):
        return ";".join(j(x) for x in r)

    k = ev.kind
    if k in ("triangles_destroyed", "edges_destroyed", "edges_created"):
        return f"{k}:{j(ev.ids)}|{rows(ev.vertices)}"
    if k == "points_destroyed":
        return f"{k}:{j(ev.ids)}"
    if k == "points_created":
        return f"{k}:{j(ev.ids)}|{j(ev.offsets)}|{j(ev.ancestors)}|" + ",".join("%.17g" % w for w in ev.weights)
    if k == "triangles_created":
        return f"{k}:{j(ev.ids)}|{rows(ev.vertices)}|{rows(ev.edges)}"
    if k.endswith("_renumbered"):
        return f"{k}:{ev.new_size}|{j(ev.old_to_new)}"
    s = ev.summary
    counts = [s["points_created"], s["points_destroyed"], s["edges_created"], s["edges_destroyed"],
              s["triangles_created"], s["triangles_destroyed"], int(s["renumbered"])]
    return f"{k}:{ev.operation}|" + ",".join(map(str, counts))


def test_callbacks_get_exactly_what_a_cpp_observer_gets(small_scene):
    small_scene["timeline"] = [{"at": 0.02, "action": "tearing", "threshold": 0.02, "maxPerStep": 3},
                               {"from": 0.0, "to": 0.05, "action": "cut",
                                "polyline": [[0.0, 0.3, 0.0], [0.5, 0.35, 0.0]]}]
    sim = cutsim.Simulation(small_scene)
    lines = []
    sim.on_topology_event(lambda ev: lines.append(as_line(ev)))
    sim._start_cpp_events()
    sim.cut([[0.0, 0.5, 0.0], [0.6, 0.5, 0.0]])
    sim.remove(sphere=([0.75, 0.25, 0.0], 0.12))
    sim.gravity = [0, 0, -200.0]
    sim.step(30)  # the progressive cut and tearing, from the steps
    sim.compact()
    sim.cut([[0.9, 0.0, 0.0], [0.9, 0.4, 0.0]])
    cpp = sim._cpp_events()
    assert sum(line.startswith("transaction_end:") for line in cpp) >= 5
    assert any(line.startswith("points_renumbered:") for line in cpp)
    assert sim.torn_edges > 0
    assert lines == cpp
