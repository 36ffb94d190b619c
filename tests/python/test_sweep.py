"""Sweeps on Dask (cutsim-sweep, cutsim.sweep: docs/sweeps.md): run folders byte for byte those of
`cutsim run`, a worker killed mid-sweep, a sweep stopped and started again, a run that diverges,
and bad input. The runs' scenes are rebuilt here independently of the sweep's code."""
import copy
import csv
import hashlib
import json
import os
import pathlib
import signal
import socket
import subprocess
import sys
import time

import numpy as np
import pytest

SOURCE = pathlib.Path(__file__).resolve().parents[2]
SMALL = SOURCE / "tests" / "data" / "scenes" / "small.json"
PYTHONPATH = os.environ.get("PYTHONPATH", "")

pytest.importorskip("distributed")


def program():
    path = os.environ.get("CUTSIM")
    if not path:
        pytest.skip("CUTSIM (the command-line program) is not set; run the tests through CTest")
    return path


def launcher():
    for d in PYTHONPATH.split(os.pathsep):
        p = pathlib.Path(d) / "cutsim-sweep"
        if p.is_file():
            return str(p)
    pytest.skip("cutsim-sweep is not next to the package on PYTHONPATH")


def sweep_cli(*args, timeout=600, **kw):
    env = dict(os.environ, CUTSIM_EXECUTABLE=program(), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, launcher(), *map(str, args)], env=env, capture_output=True,
                          text=True, timeout=timeout, **kw)


def write(path, obj):
    path.write_text(json.dumps(obj, indent=1))
    return path


def set_pointer(scene, pointer, value):
    """RFC 6901, written again here (not the sweep's code)."""
    parts = [p.replace("~1", "/").replace("~0", "~") for p in pointer.split("/")[1:]]
    node = scene
    for p in parts[:-1]:
        node = node[int(p)] if isinstance(node, list) else node[p]
    if isinstance(node, list):
        node[int(parts[-1])] = value
    else:
        node[parts[-1]] = value


def tree_digest(folder):
    """{relative path: sha256} of every file of a folder."""
    out = {}
    for root, _, files in os.walk(folder):
        for name in files:
            p = os.path.join(root, name)
            out[os.path.relpath(p, folder)] = hashlib.sha256(open(p, "rb").read()).hexdigest()
    return out


def reference_run(tmp, base, values, label):
    """The run made by hand: the base scene with the values set, in a file of the base scene's
    name (the run folder names the scene by it), run with `cutsim run`."""
    scene = copy.deepcopy(base)
    for pointer, v in values.items():
        set_pointer(scene, pointer, v)
    folder = tmp / "by-hand" / label
    folder.mkdir(parents=True)
    path = write(folder / "small.json", scene)
    out = folder / "out"
    subprocess.run([program(), "run", str(path), "--out", str(out), "--quiet"], check=True, capture_output=True, timeout=600)
    return out


def rows_of(results):
    with open(results / "results.csv", newline="") as f:
        return list(csv.DictReader(f))


def test_a_sweep_on_two_local_workers_writes_the_run_folders_of_cutsim_run(tmp_path):
    """12 runs (a 3 x 2 x 2 grid) on a local cluster of 2 workers: each run folder is byte for
    byte the one `cutsim run` writes for the same scene made by hand; the table has one row per
    run, its parameters, and quantities equal to those computed here from each run's files."""
    base = json.loads(SMALL.read_text())
    sweep = {
        "name": "twelve",
        "scene": str(SMALL),
        "parameters": [
            {"name": "k", "pointer": "/forceFields/0/stiffness", "values": [100, 200, 400]},
            {"name": "dt", "pointer": "/timeStep", "range": {"from": 0.005, "to": 0.01, "count": 2}},
            {"name": "bend", "pointer": "/forceFields/1/bendingStiffness", "values": [0.01, 0.1]},
        ],
        "extract": [
            {"name": "ke_max", "column": "kinetic_energy", "reduce": "max"},
            {"name": "ke_at", "column": "kinetic_energy", "at": 0.125},
            {"name": "slow", "first": "kinetic_energy < 0.5 * max", "after": 0.2},
            {"name": "triangles", "mesh": "triangles"},
            {"name": "pieces", "mesh": "pieces"},
        ],
        "results": "results",
    }
    path = write(tmp_path / "twelve.json", sweep)
    r = sweep_cli(path, "--workers", 2)
    assert r.returncode == 0, r.stdout + r.stderr
    results = tmp_path / "results"
    rows = rows_of(results)
    assert len(rows) == 12 and [int(x["run"]) for x in rows] == list(range(12))
    assert all(x["status"] == "done" and x["error"] == "" for x in rows), rows
    combos = [(k, dt, b) for k in (100, 200, 400) for dt in (0.005, 0.01) for b in (0.01, 0.1)]
    assert len({x["folder"] for x in rows}) == 12
    for x, (k, dt, b) in zip(rows, combos):
        assert (float(x["k"]), float(x["dt"]), float(x["bend"])) == (k, dt, b)
        mine = reference_run(tmp_path, base, {"/forceFields/0/stiffness": k, "/timeStep": dt,
                                              "/forceFields/1/bendingStiffness": b}, x["run"])
        theirs = results / x["folder"]
        assert tree_digest(theirs) == tree_digest(mine), f"run {x['run']}: the folders differ"
        # The quantities, from the run's own CSV and last frame.
        with open(mine / "steps.csv", newline="") as f:
            table = list(csv.DictReader(f))
        t = np.array([float(s["time"]) for s in table])
        ke = np.array([float(s["kinetic_energy"]) for s in table])
        assert float(x["ke_max"]) == pytest.approx(ke.max(), rel=1e-12)
        assert float(x["ke_at"]) == pytest.approx(np.interp(0.125, t, ke), rel=1e-12)
        hits = np.nonzero((ke < 0.5 * ke.max()) & (t >= 0.2))[0]
        assert x["slow"] == ("" if not hits.size else repr(float(t[hits[0]])))
        last = sorted((mine).glob("surface_*.vtp"))[-1].read_text()
        assert int(x["triangles"]) == int(last.split('NumberOfPolys="')[1].split('"')[0])
        assert int(x["pieces"]) >= 1
        assert int(x["steps"]) == len(table) - 1 and x["resumed"] == "no"
    assert (results / "summary.png").stat().st_size > 10000


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def long_scene(tmp_path, duration):
    """small.json run longer (its topology events early, then hanging), frames rarely."""
    scene = json.loads(SMALL.read_text())
    scene["duration"] = duration
    scene["output"]["every"] = 100
    scene["name"] = "small"
    (tmp_path / "long").mkdir()
    return write(tmp_path / "long" / "small.json", scene)


def cutsim_processes():
    """{pid: (parent pid, command line)} of the cutsim processes running now."""
    out = {}
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            cmd = open(f"/proc/{pid}/cmdline", "rb").read().split(b"\0")
            stat = open(f"/proc/{pid}/stat").read()
        except OSError:
            continue
        if cmd and cmd[0].endswith(b"cutsim"):
            ppid = int(stat.rsplit(")", 1)[1].split()[1])
            out[int(pid)] = (ppid, b" ".join(cmd).decode(errors="replace"))
    return out


def test_a_worker_killed_mid_sweep_leaves_every_run_completed_once(tmp_path):
    """A dask-scheduler and two dask-worker processes on 127.0.0.1; once a run has written a
    checkpoint, its worker is killed (SIGKILL): the run goes on from its checkpoint on the other
    worker, every run completes once, and every run folder is byte for byte `cutsim run`'s."""
    scene = long_scene(tmp_path, 8.0)
    port = free_port()
    env = dict(os.environ, CUTSIM_EXECUTABLE=program(), PYTHONPATH=PYTHONPATH)
    dask_bin = pathlib.Path("/usr/bin")
    address_file = tmp_path / "scheduler.json"
    procs = [subprocess.Popen([str(dask_bin / "dask-scheduler"), "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard", "--scheduler-file", str(address_file)], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        workers = [subprocess.Popen([str(dask_bin / "dask-worker"), f"tcp://127.0.0.1:{port}", "--nthreads", "1",
                                     "--no-nanny", "--no-dashboard"], env=env, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.DEVNULL) for _ in range(2)]
        procs += workers
        stiffness = [100, 150, 200, 300, 400, 600]
        sweep = {"name": "killed", "scene": str(scene), "checkpointEvery": 40,
                 "parameters": [{"name": "k", "pointer": "/forceFields/0/stiffness", "values": stiffness}],
                 "extract": [{"name": "ke_final", "column": "kinetic_energy", "reduce": "final"}],
                 "results": "results"}
        path = write(tmp_path / "killed.json", sweep)
        env_cli = dict(env, MPLBACKEND="Agg")
        deadline = time.monotonic() + 60
        while not address_file.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        client = subprocess.Popen([sys.executable, launcher(), str(path), "--scheduler-file", str(address_file),
                                   "--timeout", "30"], env=env_cli, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        runs = tmp_path / "results" / "runs"
        killed_run = None
        deadline = time.monotonic() + 120
        while killed_run is None and time.monotonic() < deadline and client.poll() is None:
            for pid, (ppid, cmd) in cutsim_processes().items():
                worker = next((w for w in workers if w.pid == ppid), None)
                if worker is None or " run " not in cmd:
                    continue
                run_id = cmd.split("--out ")[1].split()[0].rsplit("/", 1)[1]
                if (runs / run_id / "checkpoint.ckpt").exists() and not (runs / f"{run_id}.result.json").exists():
                    worker.kill()
                    killed_run = run_id
                    break
            time.sleep(0.05)
        assert killed_run is not None, "no run with a checkpoint was seen running on a worker"
        out, err = client.communicate(timeout=300)
        assert client.returncode == 0, out + err
        rows = rows_of(tmp_path / "results")
        assert len(rows) == 6 and all(r["status"] == "done" for r in rows), rows
        by_folder = {r["folder"].split("/")[-1]: r for r in rows}
        assert by_folder[killed_run]["resumed"] == "yes"
        for r in rows:
            log = (runs / (r["folder"].split("/")[-1] + ".log")).read_text()
            starts = [ln for ln in log.splitlines() if ln.startswith("$ ")]
            # Once from the start; the killed one resumed once, from its checkpoint.
            assert len([s for s in starts if " run " in s]) == 1, log
            assert len([s for s in starts if " resume " in s]) == (1 if r["folder"].endswith(killed_run) else 0), log
        base = json.loads(scene.read_text())
        for r in rows:
            mine = reference_run(tmp_path, base, {"/forceFields/0/stiffness": int(r["k"])}, r["run"])
            assert tree_digest(tmp_path / "results" / r["folder"]) == tree_digest(mine), f"run {r['run']} differs"
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
            p.wait()


def test_a_sweep_stopped_and_started_again_reruns_nothing_that_finished(tmp_path):
    """A sweep stopped as Ctrl-C would stop it (SIGINT to its process group) once some runs are
    done: started again, it runs only what had not finished (finished runs' logs and results
    untouched), the runs stopped midway go on from their checkpoints, and the folders are those
    of a sweep never stopped."""
    scene = long_scene(tmp_path, 3.0)
    sweep = {"name": "stopped", "scene": str(scene), "checkpointEvery": 40,
             "parameters": [{"name": "k", "pointer": "/forceFields/0/stiffness", "values": [100, 150, 200, 300, 400, 600]}],
             "results": "results"}
    path = write(tmp_path / "stopped.json", sweep)
    env = dict(os.environ, CUTSIM_EXECUTABLE=program(), MPLBACKEND="Agg")
    # (Ctrl-C's SIGINT as a terminal sends it: not ignored, as it is when the tests themselves run
    # as a background job of a shell, which Python would then leave ignored in the sweep too.)
    p = subprocess.Popen([sys.executable, launcher(), str(path), "--workers", "2", "--quiet"], env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    runs = tmp_path / "results" / "runs"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and p.poll() is None:
        if runs.is_dir() and len(list(runs.glob("*.result.json"))) >= 2:
            break
        time.sleep(0.05)
    os.killpg(p.pid, signal.SIGINT)
    out, err = p.communicate(timeout=120)
    assert p.returncode != 0, "the sweep was stopped before its end: " + out + err
    finished = {f.name[:-len(".result.json")]: f.read_bytes() for f in runs.glob("*.result.json")}
    assert 2 <= len(finished) < 6, finished.keys()
    logs = {k: (runs / f"{k}.log").read_bytes() for k in finished}
    r = subprocess.run([sys.executable, launcher(), str(path), "--workers", "2", "--quiet"], env=env,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    for k, blob in finished.items():
        assert (runs / f"{k}.result.json").read_bytes() == blob, f"{k} was run again"
        assert (runs / f"{k}.log").read_bytes() == logs[k], f"{k} was run again"
    rows = rows_of(tmp_path / "results")
    assert len(rows) == 6 and all(x["status"] == "done" for x in rows)
    # The same sweep never stopped, elsewhere: the same folders.
    whole = dict(sweep, name="whole", results="whole")
    r = sweep_cli(write(tmp_path / "whole.json", whole), "--workers", "2", "--quiet")
    assert r.returncode == 0, r.stdout + r.stderr
    for x, y in zip(rows, rows_of(tmp_path / "whole")):
        assert x["folder"] == y["folder"]
        assert tree_digest(tmp_path / "results" / x["folder"]) == tree_digest(tmp_path / "whole" / y["folder"])


def test_a_run_that_diverges_is_a_row_with_its_error_and_the_others_complete(tmp_path):
    scene = json.loads(SMALL.read_text())
    scene["solver"] = {"type": "explicit"}
    scene["name"] = "small"
    write(tmp_path / "small.json", scene)
    sweep = {"scene": "small.json", "results": "results",
             "parameters": [{"name": "k", "pointer": "/forceFields/0/stiffness", "values": [10, 1e5, 20]}],
             "extract": [{"name": "ke", "column": "kinetic_energy", "reduce": "max"}]}
    r = sweep_cli(write(tmp_path / "diverging.json", sweep), "--workers", "2")
    assert r.returncode == 1, r.stdout + r.stderr
    rows = rows_of(tmp_path / "results")
    assert [x["status"] for x in rows] == ["done", "failed", "done"]
    assert "blown up" in rows[1]["error"] and rows[1]["ke"] == ""
    assert float(rows[0]["ke"]) > 0 and float(rows[2]["ke"]) > 0
    assert "run 1: cutsim: error:" in r.stderr and "1 failed" in r.stdout
    # Started again, the failed run is not retried (it would fail the same way) unless asked.
    log = next((tmp_path / "results" / "runs").glob("*.log"))
    before = {f: f.read_bytes() for f in (tmp_path / "results" / "runs").glob("*.log")}
    r = sweep_cli(tmp_path / "diverging.json", "--workers", "1", "--quiet")
    assert r.returncode == 1 and {f: f.read_bytes() for f in before} == before
    r = sweep_cli(tmp_path / "diverging.json", "--workers", "1", "--quiet", "--retry-failed")
    assert r.returncode == 1 and log.exists()
    changed = [f for f, b in before.items() if f.read_bytes() != b]
    assert len(changed) == 1, changed
    # Another quantity: computed from the finished runs' folders; the failed run is not run again.
    before = {f: f.read_bytes() for f in (tmp_path / "results" / "runs").glob("*.log")}
    sweep["extract"].append({"name": "ke_end", "column": "kinetic_energy", "reduce": "final"})
    write(tmp_path / "diverging.json", sweep)
    r = sweep_cli(tmp_path / "diverging.json", "--workers", "1", "--quiet")
    assert r.returncode == 1 and {f: f.read_bytes() for f in before} == before
    rows = rows_of(tmp_path / "results")
    assert rows[0]["ke_end"] != "" and rows[1]["status"] == "failed" and rows[1]["ke_end"] == ""


def test_the_python_api_runs_a_sweep_dict(tmp_path):
    import cutsim
    rows = cutsim.sweep({"scene": str(SMALL), "name": "api",
                         "parameters": [{"pointer": "/timeStep", "values": [0.01, 0.005]}],
                         "extract": [{"name": "area", "mesh": "area"}, {"name": "angle", "mesh": "minAngle"}]},
                        results=tmp_path / "api", workers=1, progress=False, cutsim_executable=program())
    assert [r["status"] for r in rows] == ["done", "done"] and rows[0]["/timeStep"] == 0.01
    assert 0 < rows[0]["area"] < 1.0 and 0 < rows[0]["angle"] <= 60
    assert rows.csv.endswith("results.csv") and os.path.isfile(rows.picture)


def bad(tmp_path, sweep, *args, text=None):
    path = tmp_path / "bad.json"
    path.write_text(text if text is not None else json.dumps(sweep, indent=1))
    start = time.monotonic()
    r = sweep_cli(path, "--workers", "1", *args, timeout=120)
    return r, time.monotonic() - start, str(path)


GOOD = {"scene": str(SMALL), "results": "results",
        "parameters": [{"name": "k", "pointer": "/forceFields/0/stiffness", "values": [100, 200]}]}


def test_a_pointer_that_names_no_key_of_the_scene_is_refused_before_anything_runs(tmp_path):
    s = copy.deepcopy(GOOD)
    s["parameters"][0]["pointer"] = "/forceFields/0/stifness"
    r, _, path = bad(tmp_path, s)
    assert r.returncode == 2
    line = next(i for i, ln in enumerate(open(path), 1) if "stifness" in ln)
    assert f"{path}:{line}: /parameters/0/pointer: /forceFields/0/stifness names no key of the scene" in r.stderr, r.stderr
    assert "its keys: damping, stiffness, type" in r.stderr
    assert not (tmp_path / "results").exists()
    s["parameters"][0]["pointer"] = "/forceFields/7/stiffness"
    r, _, _ = bad(tmp_path, s)
    assert r.returncode == 2 and "is an array of 2 entries" in r.stderr


def test_a_value_the_scene_check_refuses_names_the_run_and_its_parameters(tmp_path):
    s = copy.deepcopy(GOOD)
    s["parameters"].append({"name": "dt", "pointer": "/timeStep", "values": [0.01, -0.01]})
    r, _, path = bad(tmp_path, s)
    assert r.returncode == 2
    assert "/parameters/1: the scene check refuses run 1 (k = 100, dt = -0.01): /timeStep:" in r.stderr, r.stderr
    assert r.stderr.startswith(f"cutsim-sweep: {path}:")
    assert not (tmp_path / "results").exists()


def test_an_unreachable_scheduler_is_a_clear_error_within_seconds(tmp_path):
    r, seconds, _ = bad(tmp_path, GOOD, "--scheduler", f"tcp://127.0.0.1:{free_port()}", "--timeout", "3")
    assert r.returncode == 2 and "cannot reach the Dask scheduler at tcp://127.0.0.1:" in r.stderr, r.stderr
    assert seconds < 30
    r, _, _ = bad(tmp_path, GOOD, "--scheduler", "nonsense://x")
    assert r.returncode == 2 and "cutsim-sweep:" in r.stderr and "Traceback" not in r.stderr, r.stderr


def test_a_results_folder_holding_another_sweeps_results_is_refused(tmp_path):
    s = dict(GOOD, name="first")
    r, _, _ = bad(tmp_path, s, "--quiet")
    assert r.returncode == 0, r.stderr
    before = tree_digest(tmp_path / "results")
    r, _, path = bad(tmp_path, dict(GOOD, name="second"))
    assert r.returncode == 2
    assert "holds the results of another sweep (\"first\"" in r.stderr, r.stderr
    assert tree_digest(tmp_path / "results") == before
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    r, _, _ = bad(tmp_path, GOOD, "--results", str(other))
    assert r.returncode == 2 and "holds files that are not a sweep's results" in r.stderr
    assert (other / "notes.txt").read_text() == "mine" and len(list(other.iterdir())) == 1


@pytest.mark.parametrize("text, where, what", [
    ('{"scene": "x.json",\n "parameters": [}', ":2: /: not valid JSON", ""),
    ('{"scene": "%s",\n "parameters": [{"pointer": "/timeStep", "values": []}]}', ":2: /parameters/0/values:", "non-empty"),
    ('{"scene": "%s",\n "parameters": [{"pointer": "/timeStep", "values": [1]}],\n "extract": [{"name": "a", "column": "time"}]}',
     ":3: /extract/0:", "\"at\""),
    ('{"scene": "%s",\n "parameters": [{"pointer": "/timeStep", "uniform": [0.001, 0.01]}]}', ":2: /parameters/0/uniform:", "samples"),
    ('{"scene": "%s",\n "parameters": [{"pointer": "/timeStep", "values": [1]}],\n "extract": [{"name": "a", "first": "time >> 2"}]}',
     ":3: /extract/0/first:", "COLUMN OP VALUE"),
    ('{"scene": "%s",\n "paramters": []}', ":2: /paramters:", "unknown key"),
    ('{"scene": "%s",\n "parameters": [{"pointer": "/timeStep", "values": [NaN]}]}', ":2: /parameters/0/values/0:", "not a finite"),
])
def test_bad_sweep_files_name_their_place(tmp_path, text, where, what):
    r, _, path = bad(tmp_path, None, text=text.replace("%s", str(SMALL)) if "%s" in text else text)
    assert r.returncode == 2 and f"{path}{where}" in r.stderr and what in r.stderr, r.stderr


def test_random_samples_are_the_same_for_the_same_seed(tmp_path):
    from cutsim.sweeps import load_sweep
    s = {"scene": str(SMALL), "samples": 5, "seed": 3,
         "parameters": [{"pointer": "/timeStep", "logUniform": [0.001, 0.01]},
                        {"pointer": "/forceFields/0/stiffness", "integers": [100, 110]}]}
    a = load_sweep(s, cutsim_executable=program(), check=False)
    b = load_sweep(s, cutsim_executable=program(), check=False)
    c = load_sweep(dict(s, seed=4), cutsim_executable=program(), check=False)
    va = [r["values"] for r in a.runs]
    assert va == [r["values"] for r in b.runs] and va != [r["values"] for r in c.runs] and len(va) == 5
    assert all(0.001 <= v["/timeStep"] <= 0.01 and 100 <= v["/forceFields/0/stiffness"] <= 110 for v in va)
    assert len({r["id"] for r in a.runs}) == 5


def test_prepared_commands_run_by_hand_are_collected_without_running_again(tmp_path):
    """--prepare writes each run's scene and one `cutsim run` a line (a job array's tasks); run
    by hand, their folders are then collected by the sweep, which runs nothing again."""
    sweep = dict(GOOD, name="array", extract=[{"name": "ke", "column": "kinetic_energy", "reduce": "max"}])
    path = write(tmp_path / "array.json", sweep)
    r = sweep_cli(path, "--prepare")
    assert r.returncode == 0, r.stdout + r.stderr
    commands = (tmp_path / "results" / "commands.txt").read_text().splitlines()
    assert len(commands) == 2 and all(" run " in c and " --out " in c for c in commands)
    for c in commands:
        subprocess.run(c, shell=True, check=True, capture_output=True, timeout=300)
    r = sweep_cli(path, "--workers", "1", "--quiet")
    assert r.returncode == 0, r.stdout + r.stderr
    rows = rows_of(tmp_path / "results")
    assert [x["status"] for x in rows] == ["done", "done"] and all(float(x["ke"]) > 0 for x in rows)
    assert not list((tmp_path / "results" / "runs").glob("*.log")), "a run was made again"
    # python3 -m cutsim.sweeps is the same program.
    env = dict(os.environ, CUTSIM_EXECUTABLE=program())
    r = subprocess.run([sys.executable, "-m", "cutsim.sweeps", str(path), "--check"], env=env, capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0 and "2 runs of" in r.stdout, r.stdout + r.stderr


@pytest.mark.parametrize("name, runs", [("tearing.json", 5), ("speed_accuracy.json", 10)])
def test_the_example_sweeps_are_well_formed(tmp_path, name, runs):
    r = sweep_cli(SOURCE / "examples" / "sweeps" / name, "--check", "--results", tmp_path / "r", timeout=120)
    assert r.returncode == 0 and f"{runs} runs of" in r.stdout, r.stdout + r.stderr


def test_the_sweep_file_and_other_files_in_the_results_folder_are_never_written_over(tmp_path):
    sweep = dict(GOOD, name="sweep", results=".")
    path = write(tmp_path / "sweep.json", sweep)
    before = path.read_bytes()
    r = sweep_cli(path, "--workers", "1")
    assert r.returncode == 2 and "holds files that are not a sweep's results (sweep.json)" in r.stderr, r.stderr
    assert path.read_bytes() == before and sorted(os.listdir(tmp_path)) == ["sweep.json"]


def test_a_parameter_named_as_a_column_of_the_table_is_refused(tmp_path):
    s = copy.deepcopy(GOOD)
    s["parameters"][0]["name"] = "status"
    r, _, path = bad(tmp_path, s)
    assert r.returncode == 2 and "/parameters/0/name: \"status\" is a column of the results table" in r.stderr, r.stderr
    s["parameters"][0]["name"] = "k"
    s["parameters"].append({"name": "k2", "pointer": "/forceFields/0", "values": [{"type": "StretchSprings"}]})
    r, _, path = bad(tmp_path, s)
    assert r.returncode == 2 and "/parameters/1: /forceFields/0 is set by the parameter \"k\" too" in r.stderr, r.stderr


def test_a_run_past_its_timeout_is_stopped_with_a_checkpoint_and_goes_on_the_next_time(tmp_path):
    scene = long_scene(tmp_path, 30.0)
    sweep = {"name": "timeout", "scene": str(scene), "timeout": 0.5, "results": "results",
             "parameters": [{"name": "k", "pointer": "/forceFields/0/stiffness", "values": [200]}]}
    path = write(tmp_path / "timeout.json", sweep)
    r = sweep_cli(path, "--workers", "1")
    assert r.returncode == 1 and "1 stopped" in r.stdout, r.stdout + r.stderr
    assert rows_of(tmp_path / "results")[0]["status"] == "stopped"
    run_dir = next(p for p in (tmp_path / "results" / "runs").iterdir() if p.is_dir())
    assert (run_dir / "checkpoint.ckpt").exists()
    sweep["timeout"] = 600  # (the run's id does not depend on it)
    write(path, sweep)
    r = sweep_cli(path, "--workers", "1")
    assert r.returncode == 0, r.stdout + r.stderr
    row = rows_of(tmp_path / "results")[0]
    assert row["status"] == "done" and row["resumed"] == "yes"
    mine = reference_run(tmp_path, json.loads(scene.read_text()), {"/forceFields/0/stiffness": 200}, "0")
    assert tree_digest(run_dir) == tree_digest(mine)


def test_quantities_that_are_not_finite_are_named_in_the_row(tmp_path):
    (tmp_path / "q.py").write_text("import math\ndef nan(run):\n    return math.nan\ndef two(run):\n    return 2\n")
    s = dict(GOOD, results="results", extract=[
        {"name": "a", "python": "q.py:nan"}, {"name": "b", "python": "q.py:two"},
        {"name": "c", "first": "kinetic_energy > max / 0"}])
    s["parameters"] = [{"pointer": "/timeStep", "values": [0.01]}]
    path = write(tmp_path / "q.json", s)
    r = sweep_cli(path, "--workers", "1", "--quiet")
    row = rows_of(tmp_path / "results")[0]
    assert row["status"] == "done" and row["a"] == "" and row["b"] == "2" and row["c"] == ""
    assert "a: nan is not a finite number" in row["error"] and "c: the condition's value" in row["error"], row
    assert "RuntimeWarning" not in r.stderr
    # A changed extraction function: the quantity again, from the run folder, nothing run again.
    (tmp_path / "q.py").write_text("import math\ndef nan(run):\n    return 1.5\ndef two(run):\n    return 2\n")
    log = next((tmp_path / "results" / "runs").glob("*.log")).read_bytes()
    r = sweep_cli(path, "--workers", "1", "--quiet")
    assert rows_of(tmp_path / "results")[0]["a"] == "1.5"
    assert next((tmp_path / "results" / "runs").glob("*.log")).read_bytes() == log


def test_a_script_that_calls_sweep_at_its_top_level_runs_once(tmp_path):
    """Dask's worker processes start by importing the main script: one without a
    `if __name__ == "__main__":` guard must not start a cluster in every worker."""
    script = tmp_path / "top.py"
    script.write_text(f"""import cutsim
rows = cutsim.sweep({{"scene": {str(SMALL)!r}, "name": "top",
                     "parameters": [{{"pointer": "/timeStep", "values": [0.01, 0.005]}}]}},
                    results={str(tmp_path / 'r')!r}, workers=2, progress=False)
print("statuses", [r["status"] for r in rows])
""")
    env = dict(os.environ, CUTSIM_EXECUTABLE=program(), MPLBACKEND="Agg")
    r = subprocess.run([sys.executable, str(script)], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.count("statuses ['done', 'done']") == 1, r.stdout + r.stderr
    assert "Traceback" not in r.stderr, r.stderr


def test_a_cutsim_that_crashes_is_a_failed_run_not_a_stopped_one(tmp_path):
    """A run whose cutsim dies of a signal other than a stop (here SIGSEGV, from a stand-in
    program) is failed, with the signal named, and not asked again as a stopped run would be."""
    fake = tmp_path / "cutsim"
    fake.write_text('#!/bin/sh\nif [ "$1" = --version ]; then echo "cutsim 0.0 (stand-in)"; exit 0; fi\n'
                    'echo "$@" >> "$0.calls"\nkill -SEGV $$\n')
    fake.chmod(0o755)
    path = write(tmp_path / "crash.json", dict(GOOD, name="crash"))
    r = sweep_cli(path, "--workers", "1", "--quiet", "--cutsim", fake)
    assert r.returncode == 1, r.stdout + r.stderr
    rows = rows_of(tmp_path / "results")
    assert [x["status"] for x in rows] == ["failed", "failed"] and all("SIGSEGV" in x["error"] for x in rows), rows
    assert len((tmp_path / "cutsim.calls").read_text().splitlines()) == 2, "a crashed run was asked again"
