"""cutsim: thin deformable surfaces (cloth, skin, membranes) cut, torn and carved while they run.

A scene is loaded from a JSON file or built from Python dicts (the same keys, registry and checks
as scene files: docs/scenes.md); the simulation is stepped from Python with the GIL released,
its state read through zero-copy numpy views, and changed between steps by topology operations,
grasps, constraints and parameters. The API and examples: docs/python.md.

    import cutsim
    sim = cutsim.load("data/scenes/hanging_cut.json")
    sim.step(10)
    x = sim.x                      # (slots, 3) read-only view of the positions, shared memory
    sim.cut([[0.3, 0.5, 0], [0.7, 0.5, 0]])
"""
import json as _jsonlib
import os as _os

import numpy as _np

from . import _cutsim
from ._cutsim import (  # noqa: F401  (the public names of the compiled part)
    Editor,
    Error,
    InvalidInputError,
    SolverError,
    SolverWarning,
    StaleViewError,
    StateView,
    TopologyError,
    TopologyEvent,
    UsageError,
    __version__,
)

__all__ = [
    "Controller", "Editor", "Error", "InvalidInputError", "Simulation", "SolverError",
    "SolverWarning", "StaleViewError", "StateView", "TopologyError", "TopologyEvent",
    "UsageError", "load", "sweep", "write_player", "__version__",
]


def _nonfinite(obj, pointer=""):
    """The JSON pointer of the first NaN or infinite number in obj, or None."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            p = _nonfinite(v, f"{pointer}/{str(k).replace('~', '~0').replace('/', '~1')}")
            if p is not None:
                return p
    elif isinstance(obj, (list, tuple, _np.ndarray)):
        for i, v in enumerate(obj):
            p = _nonfinite(v, f"{pointer}/{i}")
            if p is not None:
                return p
    elif isinstance(obj, (float, _np.floating)) and not _np.isfinite(obj):
        return (pointer or "/", obj)
    elif isinstance(obj, (int, _np.integer)) and not isinstance(obj, bool) and abs(int(obj)) > 1.7e308:
        return (pointer or "/", "an integer of %d digits" % len(str(abs(int(obj)))))
    return None


def _json(obj, what):
    """JSON text of a dict, one value per line (so that messages' line numbers mean something).
    A NaN or infinite number (which JSON cannot hold) is an InvalidInputError naming its place."""
    bad = _nonfinite(obj)
    if bad is not None:
        raise InvalidInputError(f"{what}: {bad[0]}: {bad[1]} is not a finite number")

    def default(o):
        if isinstance(o, _np.ndarray):
            return o.tolist()
        if isinstance(o, _np.generic):
            return o.item()
        if isinstance(o, _os.PathLike):
            return _os.fspath(o)
        raise TypeError(f"{what}: {type(o).__name__} is not a JSON value")
    return _jsonlib.dumps(obj, indent=1, default=default)


class Controller:
    """A controller called at each step, as SofaPython3's Sofa.Core.Controller.

    Override on_step_begin(sim) and/or on_step_end(sim); add it with sim.add_controller(c).
    Controllers may change the simulation (cut, grasp, move, release, parameters); they run with
    the GIL held, between the steps, which run with the GIL released.
    """

    def on_step_begin(self, sim):
        pass

    def on_step_end(self, sim):
        pass


class Simulation(_cutsim._Simulation):
    """A running scene.

    Simulation(path) loads a scene file (JSON, or SOFA's .scn: docs/sofa.md); Simulation(dict, base_dir=...) builds one from a dict
    with the keys of a scene file (relative mesh paths resolved against base_dir, by default the
    current folder). Bad scenes raise InvalidInputError("SOURCE:LINE: /json/pointer: message").
    """

    def __init__(self, scene, *, base_dir=None, source="<scene dict>"):
        if "_fields" in self.__dict__:
            raise TypeError("a Simulation is initialised once")
        if isinstance(scene, dict):
            base = _os.fspath(base_dir) if base_dir is not None else _os.getcwd()
            super().__init__(_json(scene, source), source, base)
            self._fields = _jsonlib.loads(_json(scene.get("forceFields", []), source))
        elif isinstance(scene, (str, _os.PathLike)):
            if base_dir is not None:
                raise TypeError("base_dir is for scenes given as dicts (a file's paths are relative to it)")
            super().__init__(_os.fspath(scene), "", "")
            if _os.fspath(scene).lower().endswith(".scn"):  # SOFA's scene: its JSON translation
                self._fields = _jsonlib.loads(_cutsim._sofa_scene_json(_os.fspath(scene))).get("forceFields", [])
            else:
                with open(scene, encoding="utf-8-sig") as f:  # read and checked by the line above
                    self._fields = _jsonlib.load(f).get("forceFields", [])
        else:
            raise TypeError(f"Simulation: expected a scene file path or a dict, got {type(scene).__name__}")

    @classmethod
    def from_dict(cls, scene, base_dir=None):
        """The scene of a dict (the keys of a scene file)."""
        return cls(scene, base_dir=base_dir)

    # ---- topology operations ----
    def cut(self, polyline, snap_tolerance=0.1, min_angle=20.0):
        """Cuts along a polyline in rest coordinates (those of sim.rest, not sim.x), then repairs
        the triangles around the cut (smallest-angle target min_angle degrees; 0: no repair).
        Returns the incision: path, copies, copied_from, inserted (point slots) and the repair's
        figures. A cut the topology refuses raises TopologyError and changes nothing (a polyline
        off the rest surface says so)."""
        polyline = _np.asarray(polyline, dtype=float)
        return self._cut(polyline, float(snap_tolerance), float(min_angle))

    def tear(self, edge=None, *, points=None, min_angle=20.0):
        """Tears one interior edge open (by its id, or by its two end points), then repairs."""
        if (edge is None) == (points is None):
            raise TypeError("tear: give either an edge id or points=(a, b)")
        if points is not None:
            if len(points) != 2:
                raise TypeError(f"tear: points=(a, b) names two points, got {points!r}")
            a, b = (_index(p, "tear: points") for p in points)
            edge = self.find_edge(a, b)
            if edge < 0:
                raise TopologyError(f"tear: points {a} and {b} share no edge")
        return self._tear(_index(edge, "tear: edge"), float(min_angle))

    def remove(self, *, sphere=None, box=None, boundary="cut", min_angle=20.0):
        """Removes the surface inside a region of rest space: sphere=(center, radius) or
        box=(min, max); boundary "cut" cuts along the region's boundary, "centroid" removes whole
        triangles (the timeline's "remove" action). Returns how many triangles fewer the surface
        has; a region that holds no triangle raises InvalidInputError."""
        entry = {"action": "remove", "boundary": boundary, "minAngle": min_angle}
        if sphere is not None:
            center, radius = sphere
            entry["sphere"] = {"center": list(map(float, center)), "radius": float(radius)}
        if box is not None:
            entry["box"] = [list(map(float, box[0])), list(map(float, box[1]))]
        before = self.num_triangles
        self.act(entry)
        return before - self.num_triangles

    def grasp(self, name, *, points=None, box=None, near=None, sphere=None, path=None, piece=None,
              seed=None):
        """Grasps points (ids, a rest-space box, or the nearest point to each position) from now
        on; path: [[t, dx, dy, dz], ...] relative to now (default: hold them where they are). A box
        takes the piece connected to its seed inside it (piece="seed", the default; seed: a
        rest-space point, default the box's centre), or every point inside (piece="all").
        sphere=(center, radius) in world coordinates takes the points of the surface as it is now
        that lie in it (one piece: the side of a cut the centre is on)."""
        entry = {"action": "grasp", "name": name, "path": path if path is not None else [[0, 0, 0, 0]]}
        if sphere is not None:
            entry["sphere"] = {"center": list(map(float, sphere[0])), "radius": float(sphere[1])}
        else:
            entry.update(_selection(points, box, near))
        if piece is not None:
            entry["piece"] = piece
        if seed is not None:
            entry["seed"] = list(map(float, seed))
        self.act(entry)

    def record(self, dir, grasps=()):
        """Writes frames and steps.csv to dir, as `cutsim run --out dir` does, from now until
        finish_recording(). The CSV has reaction-force columns for the scene's grasps, the grasps
        active now and the names in `grasps` (grasps a script will start later)."""
        self._record(_os.path.abspath(_os.fspath(dir)), list(grasps))

    def fix(self, *, points=None, box=None, near=None):
        """Fixes points (ids, a rest-space box, or the nearest point to each position) from now on."""
        entry = {"type": "fixed"}
        entry.update(_selection(points, box, near))
        if points is not None:
            alive = self.alive
            for p in entry["points"]:
                if not (0 <= p < alive.size and alive[p]):
                    raise InvalidInputError(f"fix: point {p} is not a live point of the surface")
        self._constrain(_json(entry, "fix"), "<fix>")

    def act(self, entry):
        """Adds a timeline action (a dict with the keys of a scene's timeline entry: "action" and
        the action's keys). Without "at" (or "from" and "to") it starts now."""
        if not isinstance(entry, dict):
            raise TypeError("act: expected a dict (a timeline entry)")
        entry = dict(entry)
        if "at" not in entry and "from" not in entry and "to" not in entry:
            entry["at"] = self.time
        source = f"<action {entry.get('action', '?')}>"
        self._act(_json(entry, source), source)

    # ---- callbacks ----
    def add_controller(self, controller):
        """Adds a controller: an object with on_step_begin(sim) and/or on_step_end(sim) (a
        cutsim.Controller), or SofaPython3's onAnimateBeginEvent(event) / onAnimateEndEvent(event),
        called with {"dt", "time", "sim"}."""
        names = ("on_step_begin", "on_step_end", "onAnimateBeginEvent", "onAnimateEndEvent")
        if isinstance(controller, Controller):
            kind = type(controller)
            if not any(getattr(kind, n, None) is not getattr(Controller, n, None) for n in names):
                raise TypeError(f"add_controller: {kind.__name__} overrides none of {', '.join(names)} "
                                "(a misspelt method name?)")
        super().add_controller(controller)

    # ---- parameters ----
    def parameters(self, field):
        """The scene entry (a dict) of a force field, by label, as it is now."""
        return dict(self._fields[self._field_index(field)])

    def set_parameters(self, field, changes=None, **kw):
        """Changes parameters of a force field (by label) from the next step on, with the keys of
        its scene entry: sim.set_parameters("FastTriangularBendingSprings", bendingStiffness=0.01),
        sim.set_parameters("membrane", restScale=0.98) (prestrain). The field is built anew on the
        mesh as it is now, through the registry and the checks of a scene's entry."""
        index = self._field_index(field)
        entry = {**self._fields[index], **(changes or {}), **kw}
        if entry.get("type") != self._fields[index].get("type"):
            raise InvalidInputError(f"set_parameters: \"{field}\" is a {self._fields[index].get('type')}: its "
                                    f"parameters can change, not its type")
        if entry.get("label") != self._fields[index].get("label"):
            raise InvalidInputError(f"set_parameters: \"{field}\": a force field's label cannot change")
        self._replace_field(index, _json(entry, "set_parameters"), f"<set_parameters {field}>")
        self._fields[index] = entry

    def _field_index(self, field):
        labels = self.field_labels
        if field not in labels:
            raise InvalidInputError(f"no force field labelled \"{field}\" (the scene has: {', '.join(labels)})")
        index = labels.index(field)
        if index >= len(self._fields):
            raise InvalidInputError(f"\"{field}\" is the contact: its settings are fixed when the scene is built")
        return index

    # ---- evaluations ----
    def eval(self, field, x=None, v=None):
        """(energy, forces) of one force field (by label) at positions x and velocities v
        ((slots, 3) arrays; default: the current positions and zero velocities)."""
        return self._eval(field, x, v)

    def eval_bending(self, x=None):
        """(energy, forces) of the scene's first FastTriangularBendingSprings field at x."""
        for label, kind in zip(self.field_labels, self.field_types):
            if kind == "FastTriangularBendingSprings":
                return self._eval(label, x, None)
        raise InvalidInputError("eval_bending: the scene has no FastTriangularBendingSprings field")

    def surface(self):
        """(points, triangles, slots): the live surface densely numbered (copies), as the frames
        write it: points[i] is the position of slot slots[i]; triangles index points."""
        alive = self.alive
        slots = _np.flatnonzero(alive)
        dense = _np.full(alive.shape[0], -1, dtype=_np.int64)
        dense[slots] = _np.arange(slots.size)
        return _np.array(self.x[slots]), dense[self.triangles()], slots

    def __repr__(self):
        try:
            counts = f": {self.num_points} points, {self.num_triangles} triangles"
        except UsageError:
            counts = " (stepping)"
        return f"<cutsim.Simulation '{self.name}' t={self.time:g} step {self.step_count}{counts}>"


def _index(value, what):
    """An id: an integer (not a bool, not a float with a fraction)."""
    if isinstance(value, (bool, _np.bool_)) or not isinstance(value, (int, _np.integer)):
        raise TypeError(f"{what}: expected an integer id, got {value!r}")
    return int(value)


def _selection(points, box, near):
    given = [k for k, v in (("points", points), ("box", box), ("near", near)) if v is not None]
    if len(given) != 1:
        raise TypeError("give exactly one of points=, box=, near=")
    if points is not None:
        ids = list(_np.ravel(_np.asarray(points, dtype=object)))
        if not ids:
            raise TypeError("points: expected point ids (integers), got none")
        return {"points": [_index(p, "points") for p in ids]}
    if box is not None:
        b = _np.asarray(box, dtype=float)
        if b.shape != (2, 3):
            raise ValueError(f"box: expected [[xmin, ymin, zmin], [xmax, ymax, zmax]], got {box!r}")
        return {"box": b.tolist()}
    n = _np.asarray(near, dtype=float)
    if n.ndim > 2 or n.size == 0 or n.shape[-1] != 3:
        raise ValueError(f"near: expected [x, y, z] positions, got {near!r}")
    return {"near": n.reshape(-1, 3).tolist()}


def sweep(sweep, **options):
    """Runs a parameter sweep on Dask (a sweep file or dict: docs/sweeps.md) and returns its rows;
    the options and what is written: cutsim.sweeps.sweep."""
    from .sweeps import sweep as run_sweep
    return run_sweep(sweep, **options)


def load(path):
    """The Simulation of a scene file (JSON, or SOFA's .scn)."""
    return Simulation(path)


def write_player(run_dir, output=None, max_mb=48, up="auto"):
    """Writes the player of a run folder (as `cutsim view`): one offline HTML page that plays the
    run back (docs/player.md). `run_dir` is a folder a run wrote (`cutsim run --out`, or
    `Simulation.record`), finished or not (a partial run plays under a banner). Returns a dict:
    `path` (the page, default RUN_DIR/player.html), `frames_in_run`, `frames_shown` (every k-th
    frame and the last beyond `max_mb`), `bytes`, `partial`. Raises InvalidInputError for a folder
    that is not a run or has no frames."""
    run_dir = _os.fspath(run_dir)
    output = _os.path.join(run_dir, "player.html") if output is None else _os.fspath(output)
    result = _cutsim._write_player(run_dir, output, float(max_mb), str(up))
    result["path"] = _os.fspath(result["path"])
    return result
