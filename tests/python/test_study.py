"""Fragility studies on a Dask cluster (`rockbench.fragility(study, client)`): a LocalCluster of
two worker processes the tests start and stop themselves. The distributed study must equal the
local one exactly (outcome matrix, capacities, fits, differences), survive a worker killed in
the middle of a task, and resume an interrupted study running only the missing runs."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
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
