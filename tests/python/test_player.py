"""cutsim.write_player: the player page of a run recorded from Python (docs/player.md)."""
import json
import re

import pytest

import cutsim


def _meta(page):
    text = page.read_text()
    return json.loads(re.search(r'<script type="application/json" id="cutsim-meta">(.*?)</script>', text, re.S)[1])


def test_recorded_run_gets_a_player_with_every_frame(tmp_path, small_scene):
    small_scene["timeline"] = [{"at": 0.2, "action": "cut", "polyline": [[0, 0.45, 0], [0.6, 0.45, 0]]}]
    sim = cutsim.Simulation(small_scene)
    sim.record(tmp_path / "run")
    sim.run()
    sim.finish_recording()
    result = cutsim.write_player(tmp_path / "run")
    page = tmp_path / "run" / "player.html"
    assert result["path"] == str(page) and page.is_file()
    assert result["bytes"] == page.stat().st_size and not result["partial"]
    pvd = (tmp_path / "run" / "surface.pvd").read_text()
    times = [float(t) for t in re.findall(r'timestep="([^"]+)"', pvd)]
    assert result["frames_in_run"] == result["frames_shown"] == len(times)
    meta = _meta(page)
    assert [f["t"] for f in meta["frames"]] == times
    assert meta["run"]["name"] == "small"
    assert meta["run"]["up"] == [0, 0, 1]  # against the scene's gravity
    # The cut: more triangles at the end than at the start, and lips on the border.
    assert meta["frames"][-1]["triangles"] > meta["frames"][0]["triangles"]
    assert meta["frames"][0]["lipEdges"] == 0 and meta["frames"][-1]["lipEdges"] > 0


def test_a_recording_not_finished_plays_as_partial(tmp_path, small_scene):
    sim = cutsim.Simulation(small_scene)
    sim.record(tmp_path / "run")
    sim.step(30)
    result = cutsim.write_player(tmp_path / "run", tmp_path / "p.html", max_mb=8)
    assert result["partial"] and result["frames_shown"] >= 2
    assert _meta(tmp_path / "p.html")["run"]["partial"] is True


def test_not_a_run(tmp_path):
    with pytest.raises(cutsim.InvalidInputError, match="not a cutsim run folder"):
        cutsim.write_player(tmp_path)
    with pytest.raises(cutsim.InvalidInputError, match="max_mb"):
        cutsim.write_player(tmp_path, max_mb=0)
