"""Fragility studies on a Dask cluster (`rockbench.fragility(study, client)`): a LocalCluster of
two worker processes the tests start and stop themselves. The distributed study must equal the
local one exactly (outcome matrix, capacities, fits, differences), survive a worker killed in
the middle of a task, and resume an interrupted study running only the missing runs."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import cloudpickle
import pytest
from conftest import at2
from distributed import Client, LocalCluster, WorkerPlugin

import rockbench
from rockbench.studies import spread, task_size

ROOT = Path(__file__).resolve().parents[2]
N_RECORDS = 8


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A single block on the native engine (early stops on) under 8 sine bursts: 5 stripes and
    IDA of two limit states; about a hundred runs of a few tens of milliseconds."""
    d = tmp_path_factory.mktemp("study")
    (d / "block.toml").write_text(
        'name = "block"\nduration = 1.0\n\n[[blocks]]\nname = "block"\nwidth = 0.3\n'
        'height = 1.5\n\n[contact]\nfriction = 2.0\n'
    )
    manifest = '[suite]\nname = "bursts"\n\n'
    for k in range(N_RECORDS):
        (d / f"r{k}.AT2").write_text(at2(0.5, 0.4 + 0.1 * k, 1.5 + 0.25 * (k % 3)))
        manifest += f'[[record]]\nid = "r{k}"\nfile = "r{k}.AT2"\npair = "p{k // 2}"\n\n'
    (d / "suite.toml").write_text(manifest)
    (d / "study.toml").write_text(
        'name = "bursts"\nscenes = ["block.toml"]\nsuite = "suite.toml"\nengines = ["native"]\n'
        'cache = "cache"\ntail = 2.0\n\n[intensity]\nmeasure = "pga-ratio"\n'
        "levels = [1.2, 1.6, 2.2, 3.0, 4.0]\n\n"
        "[ida]\nstart = 1.2\nfactor = 1.5\ntolerance = 0.05\nmax = 4.0\nfill = 1\n\n"
        "[fit]\nbootstrap = 40\n\n"
        '[[limit_state]]\nname = "rotation-0.5"\nkind = "rotation"\nthreshold = 0.5\n\n'
        '[[limit_state]]\nname = "overturn"\nkind = "overturn"\n'
    )
    return d / "study.toml"


@pytest.fixture(scope="module")
def local(study: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[rockbench.FragilityResult, Path]:
    out = tmp_path_factory.mktemp("local")
    res = rockbench.fragility(study, cache=out / "cache", out=out / "out")
    return res, out


@pytest.fixture(scope="module")
def client() -> Iterator[Client]:
    with LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
    ) as cluster, Client(cluster) as c:
        yield c


def cache_entries(cache: Path) -> set[str]:
    return {p.stem for p in cache.glob("*/*.json")}


def assert_same_study(a: dict[str, Any], b: dict[str, Any]) -> None:
    """Everything but the wall times and where an outcome came from (cache or run) is equal,
    floats bit for bit."""

    def rows(j: dict[str, Any]) -> list[dict[str, Any]]:
        out = []
        for r in j["rows"]:
            r = dict(r, outcome=dict(r["outcome"]))
            del r["cached"], r["outcome"]["wall_s"]
            out.append(r)
        return out

    ra, rb = rows(a), rows(b)
    assert len(ra) == len(rb) > 0
    assert ra == rb
    for k in ["capacities", "fits", "differences", "grid", "engine_versions"]:
        assert a[k] == b[k], k


def test_a_study_on_a_local_cluster_equals_the_local_run(
    study: Path, local: tuple[rockbench.FragilityResult, Path], client: Client, tmp_path: Path
) -> None:
    loc, loc_dir = local
    dist = rockbench.fragility(study, client, cache=tmp_path / "cache", out=tmp_path / "out")
    d = dist.distributed
    assert d is not None
    # Every run made once, on the workers; the assembly made none.
    assert loc.counts["made"] > 50
    assert d["made"] == loc.counts["made"]
    assert dist.counts["made"] == 0 and dist.counts["cached"] == dist.counts["runs"]
    assert cache_entries(tmp_path / "cache") == cache_entries(loc_dir / "cache")
    # Both worker processes took tasks of several runs.
    assert d["stripes"]["tasks"] >= 4 and len(d["stripes"]["pids"]) == 2
    assert_same_study(loc.json, dist.json)
    for f in ["fits.csv", "capacities.csv", "differences.csv"]:
        assert (tmp_path / "out" / f).read_bytes() == (loc_dir / "out" / f).read_bytes(), f
    # The tables and the matrix.
    assert loc.outcomes.drop(columns=["wall_s", "cached"]).equals(dist.outcomes.drop(columns=["wall_s", "cached"]))
    ds = dist.to_xarray()
    assert dict(ds.sizes) == {"scene": 1, "record": N_RECORDS, "level": 5, "engine": 1, "limit_state": 2}
    assert 0 < int(ds["exceeded"].sel(limit_state="overturn").sum()) < N_RECORDS * 5
    assert "bursts" in dist._repr_html_() and "<table" in dist._repr_html_()
    import pandas as pd

    (pq,) = [p for p in dist.to_parquet(tmp_path / "pq") if p.name == "outcomes.parquet"]
    back = pd.read_parquet(pq)
    assert back.drop(columns=["wall_s", "cached"]).equals(loc.outcomes.drop(columns=["wall_s", "cached"]))
    # The command on the same cluster: the same fits, nothing left to run.
    r = subprocess.run(
        [sys.executable, "-m", "rockbench.study", str(study), "--scheduler", client.scheduler.address,
         "--cache", str(tmp_path / "cache"), "--out", str(tmp_path / "cli"), "--quiet"],
        capture_output=True, text=True,
    )
    assert r.returncode == 0, r.stderr
    assert "0 runs made" in r.stdout, r.stdout
    assert (tmp_path / "cli" / "fits.csv").read_bytes() == (loc_dir / "out" / "fits.csv").read_bytes()
    # Each output says how it was made: the call or command, the cache it used, the cluster's
    # runs (they named a call nobody made, the study file's cache, and no cluster).
    written = {k: json.loads((tmp_path / k / "fragility.json").read_text()) for k in ["out", "cli"]}
    assert written["out"]["command"].startswith("rockbench.fragility(")
    assert f"Client({client.scheduler.address!r})" in written["out"]["command"]
    assert f"{d['made']} runs made by its workers" in written["out"]["command"]
    assert written["cli"]["command"].startswith(f"python -m rockbench.study {study}")
    assert "--scheduler" in written["cli"]["command"] and "0 runs made by its workers" in written["cli"]["command"]
    for k in written:
        assert Path(written[k]["cache_dir"]).resolve() == (tmp_path / "cache").resolve()
    assert json.loads((loc_dir / "out" / "fragility.json").read_text())["command"].startswith(
        f"rockbench.fragility({str(study)!r}, out="
    )


class KillOnce(WorkerPlugin):  # type: ignore[misc]
    """Kills its worker process (SIGKILL) during the first task any worker executes, once
    that task has stored at least one run: `marker` (created atomically) says it happened and
    whether the task was still running."""

    def __init__(self, marker: str, cache: str) -> None:
        self.marker = marker
        self.cache = cache
        self.running: set[str] = set()

    def transition(self, key: Any, start: str, finish: str, **kwargs: Any) -> None:
        k = str(key)
        if finish == "executing" and "stripes" in k:
            self.running.add(k)
            try:
                fd = os.open(self.marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                return
            threading.Thread(target=self._kill, args=(fd, k), daemon=True).start()
        elif start == "executing":
            self.running.discard(k)

    def _kill(self, fd: int, key: str) -> None:
        end = time.monotonic() + 30
        while time.monotonic() < end and not list(Path(self.cache).glob("*/*.json")):
            time.sleep(0.002)
        os.write(fd, json.dumps({"key": key, "running": key in self.running, "pid": os.getpid()}).encode())
        os.close(fd)
        os.kill(os.getpid(), signal.SIGKILL)


def test_a_worker_killed_mid_task_changes_nothing(
    study: Path, local: tuple[rockbench.FragilityResult, Path], client: Client, tmp_path: Path
) -> None:
    import test_study

    loc, _ = local
    cloudpickle.register_pickle_by_value(test_study)
    marker = tmp_path / "killed.json"
    cache = tmp_path / "cache"
    client.register_plugin(KillOnce(str(marker), str(cache)), name="kill-once")
    try:
        pids_before = set(client.run(os.getpid).values())
        dist = rockbench.fragility(study, client, cache=cache, runs_per_task=4)
    finally:
        client.unregister_worker_plugin("kill-once")
        cloudpickle.unregister_pickle_by_value(test_study)
    killed = json.loads(marker.read_text())
    assert killed["running"], "the worker was killed after its task had finished"
    assert killed["pid"] in pids_before
    client.wait_for_workers(2, timeout=60)
    assert killed["pid"] not in set(client.run(os.getpid).values())
    d = dist.distributed
    assert d is not None
    # The killed task's stored runs were kept, the rest retried on a live worker: every run
    # is in the cache once, nothing was missing when the study was assembled.
    assert dist.counts["made"] == 0
    assert d["made"] <= loc.counts["made"]
    assert len(cache_entries(cache)) == loc.counts["made"]
    assert killed["pid"] not in d["stripes"]["pids"]
    assert_same_study(loc.json, dist.json)


def test_an_interrupted_study_resumes_with_only_the_missing_runs(
    study: Path, local: tuple[rockbench.FragilityResult, Path], client: Client, tmp_path: Path
) -> None:
    loc, _ = local
    total = loc.counts["made"]
    cache = tmp_path / "cache"
    # Interrupted: the command killed (SIGKILL) once a dozen runs are stored.
    p = subprocess.Popen(
        [sys.executable, "-m", "rockbench.study", str(study), "--cache", str(cache), "--out", str(tmp_path / "o1"), "--quiet"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    end = time.monotonic() + 60
    while len(cache_entries(cache)) < 12 and time.monotonic() < end and p.poll() is None:
        time.sleep(0.005)
    p.send_signal(signal.SIGKILL)
    p.wait()
    done = len(cache_entries(cache))
    assert 12 <= done < total, "the study was not interrupted"
    assert not (tmp_path / "o1").exists(), "an interrupted study wrote outputs"
    res = rockbench.fragility(study, client, cache=cache)
    d = res.distributed
    assert d is not None
    assert d["made"] == total - done
    assert res.counts["made"] == 0 and len(cache_entries(cache)) == total
    assert_same_study(loc.json, res.json)
    # Once more: nothing left to run.
    again = rockbench.fragility(study, client, cache=cache)
    assert again.distributed is not None and again.distributed["made"] == 0


def test_run_many_gives_the_stripes_as_a_table(study: Path, client: Client, tmp_path: Path) -> None:
    here = rockbench.run_many(study, cache=tmp_path / "a")
    there = rockbench.run_many(study, client=client, cache=tmp_path / "b")
    assert len(here) == N_RECORDS * 5 and here["made"].all() and there["made"].all()
    cols = ["record", "scale", "key", "max_rotation_over_alpha", "overturned", "stop", "t_end"]
    assert here[cols].equals(there[cols])
    keys = [k for k, _ in rockbench.fragility_run_specs(study)]
    assert list(here["key"]) == keys
    again = rockbench.run_many(study, cache=tmp_path / "a")
    assert not again["made"].any()
    scenes = rockbench.run_many(
        [str(ROOT / "validation/scenes/housner-slender.toml")], engines=["native", "housner"], client=client
    )
    assert list(scenes["engine"]) == ["native", "housner"] and (scenes["status"] == "ok").all()
    # One engine's name is that engine, not its letters.
    one = rockbench.run_many([str(ROOT / "validation/scenes/housner-slender.toml")], engines="housner")
    assert list(one["engine"]) == ["housner"] and (one["status"] == "ok").all()


def test_task_size_aims_at_the_target_and_balances() -> None:
    # 5 ms runs, 2 s tasks: 400 runs a task, unless that leaves workers idle.
    assert task_size(0.005, 100_000, 2) == 400
    assert task_size(0.005, 600, 2) == 100
    assert task_size(3.0, 1000, 100) == 1
    assert task_size(0.0, 10, 1) == 4
    groups = spread(10, 3)
    assert groups == [[0, 3, 6, 9], [1, 4, 7], [2, 5, 8]]
    assert sorted(i for g in spread(97, 7) for i in g) == list(range(97))


def test_the_command_rejects_bad_input_in_one_line(study: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(study.read_text().replace("levels = [1.2,", "levels = [0,"))
    for f in ["block.toml", "suite.toml"]:
        (tmp_path / f).write_text((study.parent / f).read_text())
    r = subprocess.run(
        [sys.executable, "-m", "rockbench.study", str(bad), "--out", str(tmp_path / "o")],
        capture_output=True, text=True,
    )
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "intensity.levels" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "o").exists()
    r = subprocess.run(
        [sys.executable, "-m", "rockbench.study", str(study), "--scheduler", "tcp://127.0.0.1:9", "--timeout", "2", "--out", str(tmp_path / "o")],
        capture_output=True, text=True,
    )
    assert r.returncode == 1 and "--scheduler" in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert not (tmp_path / "o").exists()
    for seconds in ["nan", "0", "-1"]:
        r = subprocess.run(
            [sys.executable, "-m", "rockbench.study", str(study), "--task-seconds", seconds, "--out", str(tmp_path / "o")],
            capture_output=True, text=True,
        )
        assert r.returncode == 2 and r.stderr.startswith("--task-seconds must be positive"), r.stderr
        assert not (tmp_path / "o").exists()
    # A wait of 1e300 s for an unreachable scheduler hung; NaN was Dask's 400-character KeyError.
    for timeout in ["1e300", "nan", "0"]:
        r = subprocess.run(
            [sys.executable, "-m", "rockbench.study", str(study), "--scheduler", "tcp://127.0.0.1:9", "--timeout", timeout, "--out", str(tmp_path / "o")],
            capture_output=True, text=True, timeout=60,
        )
        assert r.returncode == 2 and r.stderr.startswith("--timeout: seconds to wait for the scheduler"), r.stderr
        assert r.stderr.count("\n") == 1 and not (tmp_path / "o").exists()
    # An empty cache path would have been the working directory.
    with pytest.raises(ValueError, match="cache: an empty path"):
        rockbench.fragility(study, cache="")
    with pytest.raises(ValueError, match="study: an empty path"):
        rockbench.fragility("")


def test_mujoco_and_pybullet_runs_in_the_workers_python_equal_the_worker_process_runs(
    study: Path, client: Client, tmp_path: Path
) -> None:
    """On a cluster MuJoCo and PyBullet run in the Dask worker's Python (no worker process per
    run); locally the Rust harness runs `python -m rockbench.worker`. Same outcomes."""
    text = study.read_text().replace('engines = ["native"]', 'engines = ["mujoco", "pybullet"]')
    text = text.replace("levels = [1.2, 1.6, 2.2, 3.0, 4.0]", "levels = [2.2]").split("[ida]")[0]
    one = tmp_path / "study.toml"
    one.write_text(text + "[fit]\nbootstrap = 5\n")
    (tmp_path / "suite.toml").write_text(
        '[suite]\nname = "one"\n\n[[record]]\nid = "r1"\nfile = "%s"\npair = "p0"\n' % (study.parent / "r1.AT2")
    )
    (tmp_path / "block.toml").write_text((study.parent / "block.toml").read_text())
    assert rockbench.fragility_is_python_worker("mujoco") and not rockbench.fragility_is_python_worker("native")
    loc = rockbench.fragility(one, cache=tmp_path / "a")
    dist = rockbench.fragility(one, client, cache=tmp_path / "b")
    assert dist.distributed is not None and dist.distributed["made"] == 2 == loc.counts["made"]
    assert [r["outcome"]["ran"] for r in dist.json["rows"]] == ["mujoco", "pybullet"]
    assert_same_study(loc.json, dist.json)


def test_workers_without_the_clients_filesystem_still_fill_its_store(
    study: Path, local: tuple[rockbench.FragilityResult, Path], client: Client, tmp_path: Path
) -> None:
    """Workers writing to a cache the client does not read (here: another folder): the runs
    they make come back with their tasks and the client stores them; nothing is run twice."""
    loc, loc_dir = local
    cache, elsewhere = tmp_path / "client", tmp_path / "workers"
    res = rockbench.fragility(study, client, cache=cache, worker_cache=elsewhere)
    d = res.distributed
    assert d is not None
    assert d["made"] == loc.counts["made"] == d["stored_by_client"]
    assert res.counts["made"] == 0
    assert cache_entries(cache) == cache_entries(elsewhere) == cache_entries(loc_dir / "cache")
    assert_same_study(loc.json, res.json)


def test_results_read_back_from_fragility_json_and_other_json_is_refused(
    local: tuple[rockbench.FragilityResult, Path],
) -> None:
    res, out = local
    again = rockbench.FragilityResult(json.loads((out / "out" / "fragility.json").read_text()))
    assert again.outcomes.equals(res.outcomes) and again.fits.equals(res.fits)
    summary = json.loads(next((out / "cache").glob("*/*.json")).read_text())
    for data in ({}, summary):
        with pytest.raises(ValueError, match="not a fragility study's results .*: missing study"):
            rockbench.FragilityResult(data)
    for part, value in (("limit_states", ["overturn"]), ("rows", {}), ("counts", [])):
        with pytest.raises(ValueError, match=f"not a fragility study's results .*wrong type of {part}"):
            rockbench.FragilityResult(dict(again.json, **{part: value}))


def test_run_many_sends_absolute_scene_paths_to_the_workers(
    client: Client, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A relative scene path is the client's file: the workers, started elsewhere, hold
    another `scene.toml` in their own working directory (a wider block) and must not read it."""
    text = (ROOT / "validation/scenes/housner-slender.toml").read_text()
    here, there = tmp_path / "here", tmp_path / "there"
    here.mkdir()
    there.mkdir()
    (here / "scene.toml").write_text(text)
    wide = "\n".join("width = 0.8" if line.startswith("width =") else line for line in text.splitlines())
    assert wide != text
    (there / "scene.toml").write_text(wide + "\n")
    monkeypatch.chdir(here)
    before = client.run(os.getcwd)
    client.run(os.chdir, str(there))
    try:
        dist = rockbench.run_many(["scene.toml", Path("scene.toml")], client=client)
    finally:
        for worker, cwd in before.items():
            client.run(os.chdir, cwd, workers=[worker])
    loc = rockbench.run_many(["scene.toml", Path("scene.toml")])
    other = rockbench.run_many([str(there / "scene.toml")])
    cols = ["scene", "engine", "status", "max_abs_phi", "rest_time", "impacts"]
    assert (dist["status"] == "ok").all() and len(dist) == 2
    assert dist[cols].equals(loc[cols])
    assert loc["impacts"].iloc[0] != other["impacts"].iloc[0]


def test_a_bad_task_size_is_refused_before_any_run(
    study: Path, client: Client, tmp_path: Path
) -> None:
    """task_seconds / runs_per_task are checked by the API as by the command's options: NaN
    ran the probe tasks, then failed in math.ceil; -5 made one task of every run."""
    cache = tmp_path / "cache"
    scene = str(ROOT / "validation/scenes/housner-slender.toml")
    bad: list[tuple[dict[str, Any], str]] = [
        ({"task_seconds": float("nan")}, r"task_seconds: .*\(got nan\)"),
        ({"task_seconds": float("inf")}, r"task_seconds: .*\(got inf\)"),
        ({"task_seconds": 0}, r"task_seconds: .*\(got 0\)"),
        ({"task_seconds": -1.0}, r"task_seconds: .*\(got -1.0\)"),
        ({"task_seconds": "2"}, r"task_seconds: .*\(got '2'\)"),
        ({"runs_per_task": 0}, r"runs_per_task: .*\(got 0\)"),
        ({"runs_per_task": -5}, r"runs_per_task: .*\(got -5\)"),
        ({"runs_per_task": 2.5}, r"runs_per_task: .*\(got 2.5\)"),
        ({"runs_per_task": True}, r"runs_per_task: .*\(got True\)"),
        ({"runs_per_task": float("nan")}, r"runs_per_task: .*\(got nan\)"),
    ]
    for kwargs, match in bad:
        for c in (client, None):
            with pytest.raises(ValueError, match="^fragility: " + match):
                rockbench.fragility(study, c, cache=cache, **kwargs)
            with pytest.raises(ValueError, match="^run_many: " + match):
                rockbench.run_many(study, client=c, cache=cache, **kwargs)
            with pytest.raises(ValueError, match="^run_many: " + match):
                rockbench.run_many([scene], client=c, **kwargs)
    assert not cache.exists()


def test_an_empty_worker_cache_is_refused(
    study: Path, client: Client, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """worker_cache='' (like cache='') would be the working directory: the workers wrote their
    run files there."""
    monkeypatch.chdir(tmp_path)
    cache = tmp_path / "cache"
    with pytest.raises(ValueError, match=r"^worker_cache: an empty path"):
        rockbench.fragility(study, client, cache=cache, worker_cache="")
    r = subprocess.run(
        [sys.executable, "-m", "rockbench.study", str(study), "--scheduler", client.scheduler.address,
         "--cache", str(cache), "--out", str(tmp_path / "o"), "--quiet", "--worker-cache", ""],
        capture_output=True, text=True, timeout=120, cwd=tmp_path,
    )
    assert r.returncode == 2 and r.stderr.startswith("--worker-cache: an empty path"), r.stderr
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_bad_out_is_refused_before_the_cluster_runs_anything(
    study: Path, client: Client, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`out` is checked as a local study checks it (replaceable_out), before anything is sent
    to the cluster: it had run every run there, then refused the folder."""
    cache = tmp_path / "cache"
    monkeypatch.chdir(tmp_path)
    notout = tmp_path / "notout"
    notout.mkdir()
    (notout / "precious.txt").write_text("keep")
    afile = tmp_path / "a-file"
    afile.write_text("keep")
    outs: list[tuple[str | Path, str]] = [
        (notout, r"^out: .*notout holds files and no fragility.json"),
        (afile, r"^out: .*a-file is a file, not a directory"),
        (afile / "below", r"^out: .*below: .*a-file is a file, not a directory"),
        (".", r"^out: \. is the working directory or holds it"),
        ("", r"^out: an empty path"),
    ]
    for out, match in outs:
        with pytest.raises(ValueError, match=match):
            rockbench.fragility(study, client, cache=cache, out=out)
        with pytest.raises(ValueError, match=match):
            rockbench.fragility(study, cache=cache, out=out)
    assert not cache.exists()
    for bad in [notout, notout / "precious.txt"]:
        r = subprocess.run(
            [sys.executable, "-m", "rockbench.study", str(study), "--scheduler", client.scheduler.address,
             "--cache", str(cache), "--quiet", "--out", str(bad)],
            capture_output=True, text=True, timeout=120,
        )
        assert r.returncode == 2 and r.stderr.startswith(f"--out: {bad} "), r.stderr
        assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
        assert not cache.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file", "notout"]
    assert [p.name for p in notout.iterdir()] == ["precious.txt"]


def test_a_wrong_client_is_refused_up_front(study: Path, tmp_path: Path) -> None:
    """A scheduler's address, another object or a closed client: a TypeError / ValueError
    naming `client`, not an AttributeError from inside the distribution."""
    cache = tmp_path / "cache"
    scene = str(ROOT / "validation/scenes/housner-slender.toml")
    for wrong in ["tcp://127.0.0.1:8786", object(), 3]:
        with pytest.raises(TypeError, match=r"^fragility: client: a distributed.Client that is running, or None \(got "):
            rockbench.fragility(study, wrong, cache=cache)
        with pytest.raises(TypeError, match=r"^run_many: client: a distributed.Client that is running, or None \(got "):
            rockbench.run_many(study, client=wrong, cache=cache)
        with pytest.raises(TypeError, match=r"^run_many: client: a distributed.Client that is running"):
            rockbench.run_many([scene], client=wrong)
    with pytest.raises(TypeError, match=r"\(got str 'tcp://127.0.0.1:8786'\); .*pass distributed.Client\(ADDRESS\)"):
        rockbench.fragility(study, "tcp://127.0.0.1:8786", cache=cache)
    with LocalCluster(n_workers=1, processes=False, threads_per_worker=1, dashboard_address=":0") as cl:
        closed = Client(cl)
        closed.close()
    with pytest.raises(ValueError, match=r"^fragility: client: the client is closed, not running"):
        rockbench.fragility(study, closed, cache=cache)
    with pytest.raises(ValueError, match=r"^run_many: client: the client is closed, not running"):
        rockbench.run_many(study, client=closed, cache=cache)
    with pytest.raises(ValueError, match=r"^run_many: client: the client is closed, not running"):
        rockbench.run_many([scene], client=closed)
    assert not cache.exists()


def test_run_many_refuses_bad_input_before_any_run(
    study: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    scene = str(ROOT / "validation/scenes/housner-slender.toml")
    cache = tmp_path / "cache"
    monkeypatch.chdir(tmp_path)
    typo = study.parent / "stduy.toml"
    with pytest.raises(FileNotFoundError, match="run_many: no such scene or study file: '.*stduy.toml'"):
        rockbench.run_many(typo, cache=cache)
    with pytest.raises(FileNotFoundError, match=f"run_many: no such scene or study file: '{tmp_path}/nope/missing.toml'"):
        rockbench.run_many([scene, "nope/missing.toml"])
    with pytest.raises(ValueError, match=r"^run_many: scenes\[1\]: .*study.toml is a study; give it alone"):
        rockbench.run_many([scene, study])
    with pytest.raises(ValueError, match=r"^/.*suite.toml: .*unknown field"):
        rockbench.run_many([study.parent / "suite.toml"])
    with pytest.raises(ValueError, match=r"^run_many: scenes\[0\]: .*missing field `duration`"):
        rockbench.run_many([{"name": "x"}])
    with pytest.raises(ValueError, match=r"^run_many: engines: native is given twice$"):
        rockbench.run_many([scene], engines=["native", "housner", "native"])
    assert not cache.exists()
    # A study whose name does not end in .toml is still a study (it was run as a scene).
    upper = study.parent / "study-copy.TOML"
    upper.write_text(study.read_text())
    try:
        rows = rockbench.run_many(upper, cache=cache)
    finally:
        upper.unlink()
    assert len(rows) == N_RECORDS * 5 and set(rows["record"]) == {f"r{k}" for k in range(N_RECORDS)}
    # A run that fails is a row, as before.
    two = str(ROOT / "validation/scenes/two-block-free-rocking.toml")
    failed = rockbench.run_many([two], engines="housner")
    assert len(failed) == 1 and failed["status"].iloc[0].startswith("failed: engine `housner` cannot run")


def test_the_tables_are_the_csvs(local: tuple[rockbench.FragilityResult, Path]) -> None:
    """outcomes, fits, capacities and differences have the columns of the CSVs the study
    writes, in their order (also without rows), and NaN where a CSV's cell is blank."""
    import numpy as np
    import pandas as pd

    res, out = local
    for name in ["outcomes", "fits", "capacities", "differences"]:
        csv = pd.read_csv(out / "out" / f"{name}.csv")
        table = getattr(res, name)
        assert list(table.columns) == list(csv.columns), name
        assert len(table) == len(csv), name
    assert list(res.fits.columns[6:10]) == ["theta_lo95", "theta_hi95", "beta_lo95", "beta_hi95"]
    # One engine: no differences, but the table keeps its columns; so does an empty capacities.
    assert res.differences.shape == (0, 12)
    empty = rockbench.FragilityResult(dict(res.json, capacities=[], fits=[]))
    assert empty.capacities.shape == (0, 9) and empty.fits.shape == (0, 12)
    assert list(empty.capacities.columns) == list(pd.read_csv(out / "out" / "capacities.csv").columns)
    # A run with an overturned block has no residual sliding: NaN, the CSV's blank, not inf.
    csv = pd.read_csv(out / "out" / "outcomes.csv")
    sliding = res.outcomes["max_residual_sliding_m"]
    assert res.outcomes["overturned"].any() and not np.isinf(sliding).any()
    assert (sliding.isna() == res.outcomes["overturned"]).all()
    assert (sliding.isna() == csv["max_residual_sliding_m"].isna()).all()
    assert np.allclose(sliding.dropna(), csv["max_residual_sliding_m"].dropna(), rtol=1e-5, atol=0)
    assert np.isfinite(sliding.mean())
    fits = pd.read_csv(out / "out" / "fits.csv")
    for c in ["theta", "theta_lo95", "theta_hi95", "beta_lo95", "beta_hi95"]:
        assert np.allclose(res.fits[c].astype(float), fits[c], atol=1e-6, equal_nan=True), c
    caps = pd.read_csv(out / "out" / "capacities.csv")
    assert res.capacities[["record", "limit_state"]].equals(caps[["record", "limit_state"]])
    assert np.allclose(res.capacities["capacity"], caps["capacity"])


# ---------------------------------------------------------------------------------------------
# A scheduler that is not one, has no workers, or fails during the study.


class FakeServer:
    """A TCP server in a thread of the test that is not a Dask scheduler: ``silent`` accepts
    connections and never answers (a firewall or proxy that holds them, a hung service);
    ``http`` answers any connection with an HTTP 400 (a web server, the dashboard's port)."""

    def __init__(self, mode: str) -> None:
        import socket

        self.mode = mode
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.address = f"tcp://127.0.0.1:{self.sock.getsockname()[1]}"
        self.conns: list[Any] = []
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            threading.Thread(target=self._serve, args=(conn,), daemon=True).start()

    def _serve(self, conn: Any) -> None:
        try:
            if self.mode == "http":
                conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
            while conn.recv(65536):
                pass
        except OSError:
            pass

    def close(self) -> None:
        self.sock.close()
        for c in self.conns:
            c.close()


def run_command(study: Path, *args: str, timeout: float = 60) -> tuple[subprocess.CompletedProcess[str], float]:
    start = time.monotonic()
    r = subprocess.run(
        [sys.executable, "-m", "rockbench.study", str(study), *args],
        capture_output=True, text=True, timeout=timeout,
    )
    return r, time.monotonic() - start


def test_a_scheduler_that_never_answers_is_given_up_after_the_timeout(study: Path, tmp_path: Path) -> None:
    """A server that accepts the connection and never answers: `--timeout` bounded only the
    TCP connection, and Dask's handshake waited for ever."""
    server = FakeServer("silent")
    try:
        # It waited for ever: the subprocess's own timeout tells (Python's start and imports
        # take a few seconds, more on a loaded machine).
        r, wall = run_command(
            study, "--scheduler", server.address, "--timeout", "2", "--quiet",
            "--out", str(tmp_path / "o"), "--cache", str(tmp_path / "cache"), timeout=90,
        )
    finally:
        server.close()
    assert r.returncode == 1, r.stderr
    assert r.stderr == (
        f"--scheduler {server.address}: cannot connect: no answer from a Dask scheduler "
        "within 2 s (--timeout)\n"
    )
    assert wall >= 2, wall
    assert r.stdout == "" and list(tmp_path.iterdir()) == []


def test_a_server_that_is_not_a_dask_scheduler_is_one_line(
    study: Path, client: Client, tmp_path: Path
) -> None:
    """An HTTP server (the dashboard's port, say) was a 39-line traceback ending in numpy's
    MemoryError (Dask reads "HTTP/1.1" as a frame's length); a Dask worker's address is not a
    scheduler either."""
    server = FakeServer("http")
    try:
        r, _ = run_command(
            study, "--scheduler", server.address, "--timeout", "10", "--quiet",
            "--out", str(tmp_path / "o"), "--cache", str(tmp_path / "cache"),
        )
    finally:
        server.close()
    assert r.returncode == 1, r.stderr
    assert r.stderr.startswith(f"--scheduler {server.address}: cannot connect: not a Dask scheduler ("), r.stderr
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    worker = next(iter(client.scheduler_info()["workers"]))
    r, _ = run_command(
        study, "--scheduler", worker, "--timeout", "10", "--quiet",
        "--out", str(tmp_path / "o"), "--cache", str(tmp_path / "cache"),
    )
    assert r.returncode == 1, r.stderr
    assert r.stderr == f"--scheduler {worker}: cannot connect: not a Dask scheduler (a Dask worker)\n"
    assert list(tmp_path.iterdir()) == []
    assert rockbench.studies.check_scheduler(client.scheduler.address, 10) is None


def test_a_scheduler_without_workers_is_given_up_after_the_timeout(study: Path, tmp_path: Path) -> None:
    """No worker ever joins (workers in another environment, batch jobs stuck in the queue):
    the command waited for ever, silently; the API too."""
    cache = tmp_path / "cache"
    with LocalCluster(n_workers=0, dashboard_address=":0") as cluster:
        address = cluster.scheduler_address
        r, wall = run_command(
            study, "--scheduler", address, "--timeout", "2", "--quiet",
            "--out", str(tmp_path / "o"), "--cache", str(cache), timeout=90,
        )
        assert r.returncode == 1, r.stderr
        assert r.stderr == f"--scheduler {address}: no workers joined within 2 s\n"
        assert wall >= 2, wall
        # Without --quiet it says that it waits, then the same.
        r, _ = run_command(
            study, "--scheduler", address, "--timeout", "1",
            "--out", str(tmp_path / "o"), "--cache", str(cache), timeout=90,
        )
        assert r.returncode == 1 and r.stderr == (
            f"study: the scheduler {address} has no workers; waiting up to 1 s for one to join\n"
            f"--scheduler {address}: no workers joined within 1 s\n"
        ), r.stderr
        with Client(cluster) as c:
            start = time.monotonic()
            with pytest.raises(rockbench.studies.NoWorkersError) as e:
                rockbench.fragility(study, c, cache=cache, worker_timeout=1)
            assert 1 <= time.monotonic() - start < 30
            assert isinstance(e.value, TimeoutError)
            assert str(e.value) == (
                f"fragility: client: the scheduler {address} has no workers; none joined "
                "within 1 s (worker_timeout)"
            )
            with pytest.raises(TimeoutError, match=r"^run_many: client: the scheduler .* has no workers"):
                rockbench.run_many(study, client=c, cache=cache, worker_timeout=0.5)
            # The tasks submitted were cancelled: nothing waits on the scheduler.
            assert c.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks)) == 0
            for bad in [0, -1.0, float("nan"), float("inf"), "5", True]:
                with pytest.raises(ValueError, match=r"^fragility: worker_timeout: .*\(got "):
                    rockbench.fragility(study, c, cache=cache, worker_timeout=bad)
    assert list(tmp_path.iterdir()) == []


@pytest.fixture(scope="module")
def fragile() -> Iterator[Client]:
    """A cluster of one worker process whose scheduler gives up on a task as soon as a worker
    dies running it (allowed-failures 0: KilledWorker, deterministically)."""
    import dask

    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        cluster = LocalCluster(n_workers=1, processes=True, threads_per_worker=1, dashboard_address=":0")
    with cluster, Client(cluster) as c:
        yield c


@contextmanager
def kill_once(client: Client, tmp_path: Path, cache: Path) -> Iterator[Path]:
    """The KillOnce plugin on `client`'s workers while in the block; on leaving it, wait for
    the killed worker's replacement."""
    import test_study

    marker = tmp_path / "killed.json"
    cloudpickle.register_pickle_by_value(test_study)
    client.register_plugin(KillOnce(str(marker), str(cache)), name="kill-once")
    try:
        yield marker
    finally:
        client.unregister_worker_plugin("kill-once")
        cloudpickle.unregister_pickle_by_value(test_study)
        client.wait_for_workers(1, timeout=60)


def test_a_worker_lost_mid_study_is_a_runtime_error_and_the_rerun_resumes(
    study: Path, local: tuple[rockbench.FragilityResult, Path], fragile: Client, tmp_path: Path
) -> None:
    """KilledWorker (and FutureCancelledError, CommClosedError: the scheduler lost) came out of
    rockbench.fragility as Dask's own exception; now a RuntimeError saying what happened and
    that the finished runs are cached, raised from it."""
    from distributed.scheduler import KilledWorker

    loc, _ = local
    cache = tmp_path / "cache"
    with kill_once(fragile, tmp_path, cache) as marker:
        with pytest.raises(RuntimeError) as e:
            rockbench.fragility(study, fragile, cache=cache, runs_per_task=4)
        assert json.loads(marker.read_text())["running"]
        done = len(cache_entries(cache))
        # The study's other tasks were cancelled (only the failed one is left, erred).
        states = fragile.run_on_scheduler(lambda dask_scheduler: [t.state for t in dask_scheduler.tasks.values()])
        assert set(states) <= {"erred"}, states
    assert isinstance(e.value, rockbench.studies.ClusterError)
    assert isinstance(e.value.__cause__, KilledWorker)
    assert re.fullmatch(
        r"fragility: the Dask cluster failed: a worker died running task rockbench-stripes-\S+ "
        r"\(KilledWorker: it was tried on 1 worker\(s\), all died; the last: tcp://\S+\); "
        rf"the runs finished so far are in the run cache {re.escape(str(cache))}: rerunning "
        r"the study resumes from them",
        str(e.value),
    ), str(e.value)
    assert 1 <= done < loc.counts["made"]
    # No run is made behind the caller's back once the worker is back.
    time.sleep(1.0)
    assert len(cache_entries(cache)) == done
    del e
    res = rockbench.fragility(study, fragile, cache=cache)
    assert res.distributed is not None and res.distributed["made"] == loc.counts["made"] - done
    assert_same_study(loc.json, res.json)


def test_the_command_says_in_one_line_that_a_worker_was_lost_and_the_rerun_resumes(
    study: Path, local: tuple[rockbench.FragilityResult, Path], fragile: Client, tmp_path: Path
) -> None:
    loc, _ = local
    cache = tmp_path / "cache"
    address = fragile.scheduler.address
    args = ["--scheduler", address, "--cache", str(cache), "--out", str(tmp_path / "o"), "--quiet"]
    with kill_once(fragile, tmp_path, cache):
        r, _ = run_command(study, *args, "--runs-per-task", "4")
    assert r.returncode == 1, r.stderr
    assert re.fullmatch(
        rf"--scheduler {re.escape(address)}: the Dask cluster failed: a worker died running task "
        r"rockbench-stripes-\S+ \(KilledWorker: it was tried on 1 worker\(s\), all died; the "
        rf"last: tcp://\S+\); the runs finished so far are in the run cache {re.escape(str(cache))}: "
        r"rerunning the command resumes from them\n",
        r.stderr,
    ), r.stderr
    assert not (tmp_path / "o").exists()
    done = len(cache_entries(cache))
    assert 1 <= done < loc.counts["made"]
    r, _ = run_command(study, *args)
    assert r.returncode == 0, r.stderr
    assert f"; {loc.counts['made'] - done} runs made in " in r.stdout, r.stdout


def test_a_lost_scheduler_is_a_runtime_error_from_dasks(
    study: Path, client: Client, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The scheduler lost in the middle (its process killed): Dask cancels the futures
    (FutureCancelledError, scheduler-connection-lost), or a comm closes (CommClosedError).
    Simulated on the first result the client reads."""
    import distributed
    from distributed.client import FutureCancelledError
    from distributed.comm.core import CommClosedError

    cache = tmp_path / "cache"
    real = distributed.Future.result
    for error, what in [
        (FutureCancelledError("k", "scheduler-connection-lost"),
         "the connection to the scheduler was lost (FutureCancelledError: scheduler-connection-lost)"),
        (CommClosedError("in <TCP (closed) Client->Scheduler>: Stream is closed"),
         "the connection to the scheduler was lost (CommClosedError: in <TCP (closed) Client->Scheduler>: Stream is closed)"),
    ]:
        calls = [0]

        def result(self: Any, *a: Any, _error: BaseException = error, **k: Any) -> Any:
            calls[0] += 1
            if calls[0] == 2:  # after a task whose runs were stored
                raise _error
            return real(self, *a, **k)

        monkeypatch.setattr(distributed.Future, "result", result)
        with pytest.raises(RuntimeError) as e:
            rockbench.fragility(study, client, cache=cache, runs_per_task=4)
        monkeypatch.setattr(distributed.Future, "result", real)
        assert e.value.__cause__ is error
        assert str(e.value) == (
            f"fragility: the Dask cluster failed: {what}; the runs finished so far are in the "
            f"run cache {cache}: rerunning the study resumes from them"
        )
        with pytest.raises(RuntimeError, match=r"^run_many: the Dask cluster failed: .*; no result of it was kept: rerun it$"):
            calls[0] = 0
            monkeypatch.setattr(distributed.Future, "result", result)
            rockbench.run_many([str(ROOT / "validation/scenes/housner-slender.toml")] * 2, client=client, runs_per_task=1)
        monkeypatch.setattr(distributed.Future, "result", real)
    assert len(cache_entries(cache)) >= 4


def test_a_workers_ida_runs_have_one_key_however_its_interpreter_is_spelled(
    study: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An IDA task keyed its MuJoCo and PyBullet runs by the worker's interpreter as spelled
    (python3, python, a linked folder, ``..``): one run had several keys, and the client (whose
    runs name ./.venv/bin/python) ran the workers' runs again. Another file linking to the
    interpreter (a second venv would be one) keeps its own key."""
    from rockbench import studies

    (tmp_path / "block.toml").write_text((study.parent / "block.toml").read_text())
    (tmp_path / "suite.toml").write_text(
        '[suite]\nname = "one"\n\n[[record]]\nid = "r1"\nfile = "%s"\npair = "p0"\n' % (study.parent / "r1.AT2")
    )
    mujoco = tmp_path / "study.toml"
    mujoco.write_text(
        'name = "one"\nscenes = ["block.toml"]\nsuite = "suite.toml"\nengines = ["mujoco"]\n'
        'cache = "cache"\ntail = 2.0\n\n[intensity]\nmeasure = "pga-ratio"\nlevels = [2.2]\n\n'
        '[[limit_state]]\nname = "overturn"\nkind = "overturn"\n'
    )
    venv = ROOT / ".venv" / "bin"
    (tmp_path / "linked-bin").symlink_to(venv)
    (tmp_path / "other-python").symlink_to(venv / "python")
    version = f"python{sys.version_info.major}.{sys.version_info.minor}"
    spellings = [venv / "python", venv / "python3", venv / version, venv / ".." / "bin" / "python",
                 tmp_path / "linked-bin" / "python3"]
    assert all(p.exists() for p in spellings)
    # What the Rust core keys the task's runs by: the key of the study's run made in its call.
    monkeypatch.setattr(
        studies, "fragility_ida_batch",
        lambda st, jobs, cache: (0, 0, [(rockbench.fragility_run_specs(st)[0][0], "")]),
    )

    def task_key(python: Path) -> str:
        monkeypatch.setenv("ROCKBENCH_PYTHON", "")  # restored as it was when the test ends
        monkeypatch.delenv("ROCKBENCH_PYTHON")
        monkeypatch.setattr(sys, "executable", str(python))
        (key, _), = studies.ida_task([], str(mujoco), str(tmp_path / "cache"))["runs"]
        return key

    keys = {str(p): task_key(p) for p in spellings}
    monkeypatch.delenv("ROCKBENCH_PYTHON")
    monkeypatch.chdir(ROOT)
    client = rockbench.fragility_run_specs(mujoco)[0][0]
    assert set(keys.values()) == {client}, keys
    assert task_key(tmp_path / "other-python") != client


def stripes_only(study: Path, where: Path) -> Path:
    """`study` without its IDA, in `where` (its records read where they are)."""
    (where / "block.toml").write_text((study.parent / "block.toml").read_text())
    suite = (study.parent / "suite.toml").read_text()
    (where / "suite.toml").write_text(re.sub(r'file = "(r\d+\.AT2)"', lambda m: f'file = "{study.parent / m[1]}"', suite))
    text = study.read_text()
    out = where / "stripes.toml"
    out.write_text(text.split("[ida]")[0] + "[fit]" + text.split("[fit]")[1])
    return out


def test_runs_the_workers_cache_already_holds_reach_the_clients_store(
    study: Path, client: Client, tmp_path: Path
) -> None:
    """Workers with their own cache that holds some of the study's runs (an earlier study): a
    task sent back only the runs it made, so the client's assembly ran the others again."""
    stripes = stripes_only(study, tmp_path)
    cache, elsewhere = tmp_path / "client", tmp_path / "workers"
    held = rockbench.fragility(stripes, cache=elsewhere)
    assert held.counts["made"] == held.counts["runs"] == 5 * N_RECORDS
    gone = sorted(elsewhere.glob("*/*.json"))[::4]  # a quarter the workers make again
    for p in gone:
        p.unlink()
    res = rockbench.fragility(stripes, client, cache=cache, worker_cache=elsewhere)
    d = res.distributed
    assert d is not None
    assert d["made"] == len(gone) and d["stored_by_client"] == held.counts["runs"]
    assert res.counts["made"] == 0
    assert cache_entries(cache) == cache_entries(elsewhere)
    assert_same_study(held.json, res.json)


def test_ida_runs_the_workers_cache_already_holds_reach_the_clients_store(
    study: Path, local: tuple[rockbench.FragilityResult, Path], client: Client, tmp_path: Path
) -> None:
    """An IDA task returned only the runs its hunt made, not those it read from the workers'
    own cache: the client's assembly made them again (51 runs). Now every run reaches the
    client's store, and the assembly makes none."""
    import shutil

    loc, loc_dir = local
    cache, elsewhere = tmp_path / "client", tmp_path / "workers"
    shutil.copytree(loc_dir / "cache", elsewhere)
    res = rockbench.fragility(study, client, cache=cache, worker_cache=elsewhere)
    assert res.distributed is not None and res.distributed["made"] == 0
    assert res.counts["made"] == 0
    assert cache_entries(cache) == cache_entries(elsewhere)


def _squares(xs: list[int]) -> dict[str, Any]:
    return {"results": [x * x for x in xs], "made": len(xs), "work_s": 0.0, "pid": os.getpid()}


def test_distribute_talks_only_to_its_own_client_when_another_is_current(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Inside the caller's `with Client(...)` (the current client) a study given another client
    waits for its futures with that one: Dask's `wait` takes the current client, which awaited
    another client's futures on its own event loop (a study failed with "Event ... is bound to
    a different event loop")."""
    from rockbench import studies

    with LocalCluster(n_workers=1, processes=False, threads_per_worker=1, dashboard_address=":0") as ca, \
            Client(ca) as current, \
            LocalCluster(n_workers=1, processes=False, threads_per_worker=1, dashboard_address=":0") as cb, \
            Client(cb, set_as_default=False) as given:
        calls: list[Client] = []
        sync = Client.sync

        def spy(self: Client, *args: Any, **kwargs: Any) -> Any:
            calls.append(self)
            return sync(self, *args, **kwargs)

        monkeypatch.setattr(Client, "sync", spy)
        results, info = studies.distribute(given, _squares, list(range(20)), per_task=2)
        monkeypatch.undo()
        assert results == [x * x for x in range(20)] and info["tasks"] == 10
        assert calls and all(c is given for c in calls), {id(c) for c in calls} - {id(given)}
        assert Client.current() is current


def test_a_study_whose_workers_all_left_gives_up_after_the_timeout(
    study: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Every worker leaves while the study runs (retired, scaled down: no task killed): its
    tasks waited for a worker for ever. Now, as when none joins at the start: the study ends
    after `worker_timeout` s without a worker, its tasks cancelled, saying where its runs are."""
    from rockbench import studies

    store = studies.fragility_store

    def store_then_retire(cache: Any, runs: Any) -> int:
        # The first task's runs are stored, then every worker leaves.
        n = store(cache, runs)
        if c.nthreads():
            cluster.scale(0)
        return n

    monkeypatch.setattr(studies, "fragility_store", store_then_retire)
    cache = tmp_path / "cache"
    with LocalCluster(n_workers=1, processes=False, threads_per_worker=1, dashboard_address=":0") as cluster, \
            Client(cluster) as c:
        address = cluster.scheduler_address
        start = time.monotonic()
        with pytest.raises(studies.NoWorkersError) as e:
            rockbench.fragility(study, c, cache=cache, runs_per_task=4, worker_timeout=1)
        assert 1 <= time.monotonic() - start < 30
        assert isinstance(e.value, TimeoutError) and e.value.left
        assert str(e.value) == (
            f"fragility: client: every worker left the scheduler {address}; none joined within 1 s "
            f"(worker_timeout); the runs finished so far are in the run cache {cache}: rerunning "
            "the study resumes from them"
        )
        assert len(cache_entries(cache)) >= 4
        # The tasks were cancelled: nothing waits on the scheduler.
        assert c.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks)) == 0
        # The command says it in one line.
        cluster.scale(1)
        c.wait_for_workers(1, timeout=30)
        code = studies.main(
            [str(study), "--scheduler", address, "--cache", str(cache), "--out", str(tmp_path / "o"),
             "--timeout", "1", "--quiet", "--runs-per-task", "4"]
        )
        err = capsys.readouterr().err
        assert code == 1 and err == (
            f"--scheduler {address}: every worker left and none joined within 1 s; the runs "
            f"finished so far are in the run cache {cache}: rerunning the command resumes from them\n"
        ), err
        assert not (tmp_path / "o").exists()
