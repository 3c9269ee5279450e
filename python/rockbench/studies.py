"""Studies past one machine: fragility studies and batches of runs, on a Dask cluster or locally.

    python -m rockbench.study STUDY.toml [--scheduler ADDRESS] [--out DIR] [--cache DIR]

(the command is `rockbench.study`, which calls :func:`main`)

- ``fragility(study, client=None)``: a fragility study (``rockbench fragility``). Without a
  client the Rust core runs it on this machine. With a ``distributed.Client`` the runs the study
  is missing from its run cache are cut into tasks of many runs, the stripes first, then the
  IDA hunts (a record's hunt is sequential: one IDA job is one record), and run on the
  cluster; each task calls the Rust core with the GIL released and stores every outcome in the
  run cache under its content hash (temporary file + rename), and sends the outcomes it made
  back, which the client stores too as each task ends (so results reach the client's store
  even when workers do not share its filesystem). The study is then assembled by
  the same Rust code as a local study, from the cache, with no new run: the outcome matrix and
  the fits are the local ones, bit for bit. An interrupted study, or one whose worker died,
  resumes from the cache: finished runs are never run again.
- ``run_many(scenes_or_study, ...)``: many runs as a DataFrame; a study file gives its stripes'
  runs (through the same cache), a list of scenes one run per scene and engine.

MuJoCo and PyBullet runs execute in the Dask worker's own Python: the worker code of
``python -m rockbench.worker`` (``rockbench.worker.run``) is called in-process with the study's
early-stop rule (``fragility_worker_early_stop``, the rule the harness gives a worker process),
and its outputs are read by the same Rust code that reads the worker process's outputs. (Inside IDA hunts,
which the Rust core drives, they run as worker processes of the Dask worker's interpreter.)

The cluster's workers need ``rockbench`` installed and the study's record files at the same
paths as the client; a run cache they share with the client (a shared filesystem) also lets a
task skip runs another finished; see docs/cluster.md.
"""

from __future__ import annotations

import argparse
import asyncio
import errno
import json
import math
import numbers
import os
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, TypeVar

import pandas as pd  # type: ignore[import-untyped]  # pandas ships no stubs for 3.x

from rockbench._native import (
    Scene,
    check_engine_names,
    check_study_out,
    fragility_cache_dir,
    fragility_cache_has,
    fragility_ida_batch,
    fragility_ida_jobs,
    fragility_is_python_worker,
    fragility_run_batch,
    fragility_run_specs,
    fragility_store,
    fragility_study,
    fragility_worker_early_stop,
    fragility_worker_outcome,
    fragility_worker_scene,
    load_scene,
    run,
)
from rockbench.results import FragilityResult, outcome_row

T = TypeVar("T")
PathLike = str | os.PathLike[str]

#: Default wall time of one task, s: long enough that the cost of a task to the scheduler,
#: client and worker (6-8 ms measured on a loaded 2-core machine, docs/cluster.md) stays far
#: below 5 %, short enough to balance the load.
TASK_SECONDS = 2.0


# ---------------------------------------------------------------------------------------------
# Tasks (module-level functions: they run in the Dask workers).


def run_specs_task(items: list[tuple[str, str]], cache: str) -> dict[str, Any]:
    """Run `(key, spec_json)` runs through the run cache `cache`: Rust engines in one call to
    the core (GIL released), MuJoCo and PyBullet in this Python. Returns the outcomes, how many
    runs were made, and the task's working time."""
    start = time.perf_counter()
    rust: list[tuple[int, str]] = []
    py: list[tuple[int, str, str]] = []
    for i, (key, spec) in enumerate(items):
        engine = json.loads(spec)["engine"]
        if fragility_is_python_worker(engine):
            py.append((i, key, spec))
        else:
            rust.append((i, spec))
    out: list[tuple[str, bool, str] | None] = [None] * len(items)
    if rust:
        for (i, _), r in zip(rust, fragility_run_batch([s for _, s in rust], cache)):
            out[i] = r
    for i, key, spec in py:
        out[i] = _python_worker_run(key, spec, cache)
    results = [r for r in out if r is not None]
    return {
        "results": results,
        "made": sum(1 for r in results if r[1]),
        "work_s": time.perf_counter() - start,
        "pid": os.getpid(),
    }


def _python_worker_run(key: str, spec: str, cache: str) -> tuple[str, bool, str]:
    """One MuJoCo or PyBullet run in this process (the code of ``python -m rockbench.worker``),
    its outcome made and stored by the Rust core."""
    from rockbench import worker

    if fragility_cache_has(cache, [key])[0]:
        ((_, _, text),) = fragility_run_batch([spec], cache)
        return key, False, text
    s = json.loads(spec)
    engine = s["engine"]
    with tempfile.TemporaryDirectory(prefix=f"rockbench-{engine}-") as d:
        scene_json = os.path.join(d, "scene.json")
        with open(scene_json, "w") as f:
            f.write(fragility_worker_scene(spec))
        # The study's early-stop rule, as the harness gives it to a worker process.
        rule = fragility_worker_early_stop(spec)
        rule_json = None
        if rule is not None:
            rule_json = os.path.join(d, "early_stop.json")
            with open(rule_json, "w") as f:
                f.write(rule)
        start = time.perf_counter()
        try:
            worker.run(
                engine, scene_json, os.path.join(d, "out"), s["scene"].get("source"), rule_json
            )
        except worker.WorkerError as e:
            raise RuntimeError(f"{engine}: record {s['record_id']} x{s['scale']}: {e}") from None
        wall = time.perf_counter() - start
        text = fragility_worker_outcome(spec, os.path.join(d, "out"), wall, cache)
    return key, True, text


def ida_task(jobs: list[tuple[int, str, str]], study: str, cache: str) -> dict[str, Any]:
    """Hunt and fill the IDA of `jobs` (scene index, engine, record id) through the cache. The
    Rust core drives the hunt; MuJoCo and PyBullet runs in it are worker processes of this
    worker's own interpreter (``ROCKBENCH_PYTHON``, unless set; the runs' keys name it spelled
    one way, however it is spelled here)."""
    os.environ.setdefault("ROCKBENCH_PYTHON", sys.executable)
    start = time.perf_counter()
    made, cached, runs = fragility_ida_batch(study, jobs, cache)
    return {
        "results": [None] * len(jobs),
        "runs": runs,
        "made": made,
        "cached": cached,
        "work_s": time.perf_counter() - start,
        "pid": os.getpid(),
    }


def scenes_task(items: list[tuple[Any, str]]) -> dict[str, Any]:
    """Run `(scene, engine)` pairs; per pair, one row per block of the run (a failed run: one
    row with its reason)."""
    start = time.perf_counter()
    rows = [_scene_rows(scene, engine) for scene, engine in items]
    return {"results": rows, "made": len(items), "work_s": time.perf_counter() - start, "pid": os.getpid()}


def _scene_rows(scene: Any, engine: str) -> list[dict[str, Any]]:
    name = scene if isinstance(scene, str) else scene.get("name", "<dict>")
    try:
        r = run(scene, engine=engine)
    except (RuntimeError, ValueError) as e:
        return [{"scene": name, "engine": engine, "status": f"failed: {e}"}]
    s = r.summary
    rows = []
    for b in s["blocks"]:
        rows.append(
            {
                "scene": s["scene"],
                "engine": engine,
                "status": s["status"],
                "engine_version": s["engine_version"],
                "wall_time_s": s["wall_time_s"],
                "block": b["name"],
                "max_abs_phi": b["max_abs_phi"],
                "overturned": b["overturned"],
                "overturn_time": b["overturn_time"],
                "rest_time": b["rest_time"],
                "impacts": len(b["impacts"]),
            }
        )
    return rows


# ---------------------------------------------------------------------------------------------
# Cutting work into tasks.


def task_size(per_item_s: float, remaining: int, slots: int, task_seconds: float = TASK_SECONDS) -> int:
    """Items per task: enough for `task_seconds` of work at `per_item_s` each, but no more
    than leaves every one of `slots` worker threads about three tasks (load balance, and a
    worker's death loses little)."""
    if remaining <= 0:
        return 1
    want = math.ceil(task_seconds / per_item_s) if per_item_s > 0 else remaining
    cap = max(1, math.ceil(remaining / (3 * max(1, slots))))
    return max(1, min(want, cap))


def _chunks(items: Sequence[T], size: int) -> list[list[T]]:
    return [list(items[i : i + size]) for i in range(0, len(items), size)]


def spread(n: int, parts: int) -> list[list[int]]:
    """Indices 0..n-1 dealt into `parts` groups like cards (group j: j, j + parts, ...): a
    study lists its runs record by record and level by level, and run costs follow the level,
    so dealt groups cost about the same and a sample of a few groups measures the average."""
    parts = max(1, min(parts, n))
    return [list(range(j, n, parts)) for j in range(parts)]


class NoWorkersError(TimeoutError):
    """The Dask scheduler has no workers and none joined within the wait allowed
    (`worker_timeout` of :func:`fragility` / :func:`run_many`, ``--timeout`` of the command):
    it had none when the study started (`left` False: nothing of the study ran), or every
    worker left while it ran (`left` True: the runs finished before are in the run cache
    `cache`, None for ``run_many`` of scenes). Its tasks were cancelled."""

    def __init__(
        self, message: str, address: str, timeout: float, left: bool = False, cache: str | None = None
    ) -> None:
        super().__init__(message)
        self.address = address
        self.timeout = timeout
        self.left = left
        self.cache = cache


class ClusterError(RuntimeError):
    """The Dask cluster failed during a study: a task's worker died (``KilledWorker``), the
    connection to the scheduler was lost (``FutureCancelledError``, ``CommClosedError``), ...
    Raised from the Dask exception (``__cause__``). `what` says what happened; the runs that
    finished before are in the run cache `cache` (None: there is none, for ``run_many`` of
    scenes), and rerunning the study resumes from them."""

    def __init__(self, message: str, what: str, cache: str | None) -> None:
        super().__init__(message)
        self.what = what
        self.cache = cache


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _cluster_failure(e: BaseException) -> str | None:
    """What a Dask exception raised while a study's tasks ran says happened to the cluster,
    in a few words; None: not a failure of the cluster (a task's own error, a bug)."""
    from concurrent.futures import CancelledError

    from distributed.comm.core import CommClosedError
    from distributed.scheduler import KilledWorker

    if isinstance(e, KilledWorker):
        last = getattr(e.last_worker, "address", e.last_worker)
        return (
            f"a worker died running task {e.task} (KilledWorker: it was tried on "
            f"{e.allowed_failures + 1} worker(s), all died; the last: {last})"
        )
    if isinstance(e, CancelledError):
        reason = getattr(e, "reason", None)
        if reason == "scheduler-connection-lost":
            return f"the connection to the scheduler was lost ({type(e).__name__}: {reason})"
        return _one_line(f"a task was cancelled ({type(e).__name__}: {reason or e})")
    if isinstance(e, CommClosedError):
        return _one_line(f"the connection to the scheduler was lost ({type(e).__name__}: {e})")
    return None


def _await_workers(
    client: Any, futures: list[Any], timeout: float | None, function: str,
    progress: Callable[[str], None] | None,
) -> None:
    """The scheduler has no worker: wait (after the first tasks were submitted, so that an
    adaptive cluster scales up) until one joins, at most `timeout` s (None: for ever); else
    cancel `futures` and raise :class:`NoWorkersError`."""
    address = str(getattr(client.scheduler, "address", client))
    if progress:
        wait = "for ever" if timeout is None else f"up to {timeout:g} s"
        progress(f"the scheduler {address} has no workers; waiting {wait} for one to join")
    try:
        client.wait_for_workers(1, timeout=timeout)
    except TimeoutError:
        client.cancel(futures)
        raise NoWorkersError(
            f"{function}: client: the scheduler {address} has no workers; none joined within "
            f"{timeout:g} s (worker_timeout)",
            address,
            float(timeout or 0),
        ) from None


#: How often a study whose tasks are all waiting asks the scheduler whether it has workers, s.
WORKER_POLL_S = 1.0


def _check_workers_present(
    client: Any, inflight: dict[Any, Any], absent_since: float | None, timeout: float | None,
    function: str, progress: Callable[[str], None] | None,
) -> float | None:
    """No task ended for a while: whether the scheduler still has workers. When it has none
    (they all left: the tasks wait for one), when it was first seen without (None: it has
    some); none for `timeout` s (None: wait for ever): cancel `inflight` and raise
    :class:`NoWorkersError`."""
    if client.nthreads():
        return None
    now = time.monotonic()
    address = str(getattr(client.scheduler, "address", client))
    if absent_since is None:
        if progress:
            wait = "for ever" if timeout is None else f"up to {timeout:g} s"
            progress(f"every worker left the scheduler {address}; waiting {wait} for one to join")
        return now
    if timeout is not None and now - absent_since >= timeout:
        client.cancel(list(inflight.values()))
        inflight.clear()
        raise NoWorkersError(
            f"{function}: client: every worker left the scheduler {address}; none joined "
            f"within {timeout:g} s (worker_timeout)",
            address,
            float(timeout),
            left=True,
        )
    return absent_since


def distribute(
    client: Any,
    fn: Callable[..., dict[str, Any]],
    items: Sequence[Any],
    args: tuple[Any, ...] = (),
    *,
    probe: int = 2,
    task_seconds: float = TASK_SECONDS,
    per_task: int | None = None,
    window: int = 4,
    label: str = "runs",
    progress: Callable[[str], None] | None = None,
    on_result: Callable[[dict[str, Any]], None] | None = None,
    worker_timeout: float | None = None,
    function: str = "distribute",
) -> tuple[list[Any], dict[str, Any]]:
    """Run `fn(batch, *args)` over `items` on a Dask client; `fn` returns a dict with
    ``results`` (one per item of its batch), ``made`` and ``work_s``. Tasks take items dealt
    across the list (:func:`spread`). Unless `per_task` is given, probe tasks of `probe` items
    (one per worker thread, at least 8 items in all, evenly spaced over the list) measure an
    item's cost, then the rest is cut into tasks of :func:`task_size`. At most `window` tasks per worker thread are submitted at a time (the
    scheduler holds a bounded amount of work; a new task goes out as one ends). `on_result` is
    called with each task's result as it arrives. Returns the results in item order and
    statistics.

    A scheduler with no workers: once the first tasks are submitted (an adaptive cluster
    scales up for them), wait for one to join, at most `worker_timeout` s (None: for ever),
    else cancel them and raise :class:`NoWorkersError` (its message starts with
    `function`). The same once every worker has left while tasks remain: no worker for
    `worker_timeout` s, and :class:`NoWorkersError` with `left` True."""
    from concurrent.futures import CancelledError

    from distributed import wait

    start = time.perf_counter()
    nthreads = client.nthreads()
    slots = max(1, sum(nthreads.values()))
    no_workers = [not nthreads]  # none yet: wait for one after the first submissions
    items = list(items)
    batches: list[list[int]] = []
    results: dict[int, dict[str, Any]] = {}
    index: dict[Any, int] = {}
    inflight: dict[Any, Any] = {}  # key -> future submitted and not yet ended
    done_items = 0
    last = [0.0]  # when the last progress line was printed (at most one a second)

    def submit(batch: list[int]) -> Any:
        batches.append(batch)
        key = f"rockbench-{label}-{os.getpid()}-{time.time_ns()}-{len(batches)}"
        f = client.submit(fn, [items[i] for i in batch], *args, pure=False, key=key)
        index[f.key] = len(batches) - 1
        inflight[f.key] = f
        return f

    def run_all(todo: list[list[int]]) -> None:
        nonlocal done_items, slots
        pending = iter(todo)
        first = [submit(b) for _, b in zip(range(window * slots), pending)]
        if no_workers[0] and first:
            _await_workers(client, first, worker_timeout, function, progress)
            no_workers[0] = False
            slots = max(1, sum(client.nthreads().values()))
        absent_since: float | None = None  # when the scheduler was last seen without workers
        try:
            while inflight:
                try:
                    # Dask's `wait` waits with the current client, not the futures' own:
                    # `client` is made current here, else another (the caller's `with
                    # Client(...)`) would await these futures on its own event loop.
                    with client.as_current():
                        ended = wait(  # type: ignore[no-untyped-call]
                            list(inflight.values()), timeout=WORKER_POLL_S, return_when="FIRST_COMPLETED"
                        ).done
                except TimeoutError:
                    ended = set()
                except CancelledError:
                    # Cancelled futures (the scheduler lost): their results raise what happened.
                    ended = {f for f in inflight.values() if f.done()}
                if not ended:
                    absent_since = _check_workers_present(
                        client, inflight, absent_since, worker_timeout, function, progress
                    )
                    continue
                absent_since = None
                for fut in sorted(ended, key=lambda f: index[f.key]):
                    del inflight[fut.key]
                    r = fut.result()
                    if on_result:
                        on_result(r)
                    i = index[fut.key]
                    results[i] = r
                    done_items += len(batches[i])
                    fut.release()
                    nxt = next(pending, None)
                    if nxt is not None:
                        submit(nxt)
                    if progress and (time.perf_counter() - last[0] >= 1.0 or done_items == len(items)):
                        last[0] = time.perf_counter()
                        progress(f"{label}: {done_items}/{len(items)} done ({len(results)} tasks)")
        except BaseException as e:
            # A task failed (its worker died, its own error, ...): the study's other tasks
            # must not go on running on the cluster once this call has raised. (Not when the
            # scheduler is lost: the client has cancelled them, and asking it would wait.)
            lost = isinstance(e, (CancelledError, OSError))
            if inflight and not lost and client.status == "running":
                try:
                    client.cancel(list(inflight.values()))
                except Exception:  # noqa: BLE001  the failure being raised says more
                    pass
            inflight.clear()
            raise

    left = list(range(len(items)))
    size = per_task
    if size is None and items:
        n = min(len(items), max(probe * slots, 8))
        probes = [left[(k * len(left)) // n] for k in range(n)]
        run_all([probes[k : k + max(1, probe)] for k in range(0, n, max(1, probe))])
        work = sum(r["work_s"] for r in results.values())
        taken = set(probes)
        left = [i for i in left if i not in taken]
        size = task_size(work / n, len(left), slots, task_seconds)
    if left:
        groups = spread(len(left), math.ceil(len(left) / (size or 1)))
        run_all([[left[k] for k in g] for g in groups])
    wall = time.perf_counter() - start
    per_item: list[Any] = [None] * len(items)
    for i, r in results.items():
        for item, x in zip(batches[i], r["results"]):
            per_item[item] = x
    tasks = [results[i] for i in range(len(batches))]
    work = sum(r["work_s"] for r in tasks)
    stats = {
        "items": len(items),
        "tasks": len(batches),
        "task_size": size,
        "made": sum(int(r["made"]) for r in tasks),
        "work_s": work,
        "wall_s": wall,
        "slots": slots,
        "pids": sorted({int(r["pid"]) for r in tasks}),
    }
    return per_item, stats


# ---------------------------------------------------------------------------------------------
# The API.


# The longest wait for a Dask scheduler, s (a longer one is a slip: it waited for ever).
MAX_TIMEOUT = 3600.0


def _positive_seconds(value: Any) -> bool:
    """Whether `value` is a number of seconds: a real number (not a bool), finite, above 0."""
    return (
        not isinstance(value, bool)
        and isinstance(value, numbers.Real)
        and math.isfinite(value)
        and float(value) > 0
    )


def _check_task_size(function: str, task_seconds: Any, runs_per_task: Any) -> None:
    """Refuse a task size that is not one (the command's --task-seconds / --runs-per-task
    checks), before anything runs: `task_seconds` a finite number of seconds above 0,
    `runs_per_task` None or a whole number (not a bool) of at least 1."""
    if not _positive_seconds(task_seconds):
        raise ValueError(
            f"{function}: task_seconds: the target wall time of a task, a finite number of "
            f"seconds above 0 (got {task_seconds!r})"
        )
    if runs_per_task is not None and (
        isinstance(runs_per_task, bool)
        or not isinstance(runs_per_task, numbers.Integral)
        or int(runs_per_task) < 1
    ):
        raise ValueError(
            f"{function}: runs_per_task: a whole number of runs (IDA: records) per task, at "
            f"least 1, or None (got {runs_per_task!r})"
        )


#: The default wait for a worker when the scheduler has none (at the start, or once every
#: worker has left), s (`worker_timeout`).
WORKER_TIMEOUT = 120.0


def _check_worker_timeout(function: str, worker_timeout: Any) -> None:
    """`worker_timeout`: None (wait for ever) or a finite number of seconds above 0."""
    if worker_timeout is not None and not _positive_seconds(worker_timeout):
        raise ValueError(
            f"{function}: worker_timeout: seconds to wait for a first worker when the scheduler "
            f"has none, a finite number above 0, or None (for ever) (got {worker_timeout!r})"
        )


def _distributed(function: str, cache: str | None, call: Callable[[], T]) -> T:
    """`call()`, which runs tasks on the cluster; a failure of the cluster (a worker died, the
    scheduler was lost) is raised as a :class:`ClusterError` saying so, from the Dask
    exception."""
    try:
        return call()
    except NoWorkersError as e:
        if not e.left or cache is None:
            raise
        raise NoWorkersError(
            f"{e}; the runs finished so far are in the run cache {cache}: rerunning the study "
            "resumes from them",
            e.address,
            e.timeout,
            left=True,
            cache=cache,
        ) from None
    except Exception as e:
        what = _cluster_failure(e)
        if what is None:
            raise
        if cache is None:
            kept = "no result of it was kept: rerun it"
        else:
            kept = (
                f"the runs finished so far are in the run cache {cache}: rerunning the study "
                "resumes from them"
            )
        raise ClusterError(f"{function}: the Dask cluster failed: {what}; {kept}", what, cache) from e


def _scheduler_address(client: Any) -> str:
    """The address of `client`'s scheduler, as its outputs record it."""
    try:
        return str(client.scheduler.address)
    except AttributeError:
        return "?"


def _check_client(function: str, client: Any) -> None:
    """Refuse a `client` that is not a running ``distributed.Client`` (None: run here), before
    anything runs."""
    if client is None:
        return
    try:
        from distributed import Client
    except ImportError:
        raise TypeError(
            f"{function}: client: a distributed.Client that is running, or None (got "
            f"{type(client).__name__}); Dask is not installed: pip install 'rockbench[dask]'"
        ) from None
    if not isinstance(client, Client):
        hint = (
            "; to use a scheduler at that address, pass distributed.Client(ADDRESS)"
            if isinstance(client, str)
            else ""
        )
        shown = repr(client)
        shown = shown if len(shown) <= 80 else shown[:77] + "..."
        raise TypeError(
            f"{function}: client: a distributed.Client that is running, or None (got "
            f"{type(client).__name__} {shown}){hint}"
        )
    status = getattr(client, "status", None)
    if status != "running":
        raise ValueError(
            f"{function}: client: the client is {status}, not running (a distributed.Client "
            "that is running, or None)"
        )


def check_out(out: PathLike, cache_dir: PathLike, what: str = "out") -> Path:
    """Check, before a study runs, that `out` can take its outputs, as the command line does
    (``check_study_out`` of the Rust core, which checks again when it writes them): they replace
    the folder whole, so it must be new, empty or a study's output (it holds fragility.json),
    neither the working directory nor one that holds it, and not hold the run cache
    `cache_dir`; the folder it is in must be one this process can write in (the outputs are
    written next to it, then renamed). `what` names the argument in the message (``out``,
    ``--out``). Gives `out` made absolute (symbolic links kept)."""
    if str(out) == "":
        raise ValueError(f"{what}: an empty path (it would be the working directory)")
    try:
        return Path(check_study_out(Path(out), Path(cache_dir)))
    except ValueError as e:
        msg = str(e)
        raise ValueError(what + msg[len("--out") :] if msg.startswith("--out") else msg) from None


def _paths(study: PathLike, cache: PathLike | None) -> tuple[Path, Path]:
    if str(study) == "":
        raise ValueError("study: an empty path")
    if cache is not None and str(cache) == "":
        raise ValueError("cache: an empty path (it would be the working directory)")
    path = Path(study).resolve()
    cache_dir = Path(cache).resolve() if cache is not None else Path(fragility_cache_dir(path))
    return path, cache_dir


def fragility(
    study: PathLike,
    client: Any = None,
    *,
    out: PathLike | None = None,
    cache: PathLike | None = None,
    worker_cache: PathLike | None = None,
    task_seconds: float = TASK_SECONDS,
    runs_per_task: int | None = None,
    quiet: bool = True,
    worker_timeout: float | None = WORKER_TIMEOUT,
    command: str | None = None,
) -> FragilityResult:
    """Run the fragility study `study` (a study TOML file) and return its results; with `out`,
    also write outcomes.csv, fits.csv, ..., report.html there. `client`: a
    ``distributed.Client`` (None: run here). `cache`: the run cache, the store of results
    (default: the study's). `worker_cache`: the cache path the workers use (default `cache`;
    another path when workers do not share the client's filesystem: their runs come back with
    the tasks and are stored in `cache` as each task ends). `task_seconds` / `runs_per_task`
    size the tasks (``runs_per_task`` also sizes IDA tasks, in records). `worker_timeout`: how
    long to wait for a first worker when the scheduler has none, or for one to come back when
    every worker has left (s; None: for ever), else :class:`NoWorkersError` (a TimeoutError
    naming the scheduler).

    A failure of the cluster while the study runs (a task's worker died: ``KilledWorker``; the
    connection to the scheduler lost: ``FutureCancelledError``, ``CommClosedError``) raises a
    :class:`ClusterError` (a RuntimeError, from the Dask exception) saying what happened; the
    runs that finished are in the run cache and rerunning the study resumes from them.

    Bad input is refused before anything runs: a `client` that is not a running
    ``distributed.Client`` (TypeError / ValueError), an empty `cache` or `worker_cache`, a
    `task_seconds` that is not a finite number above 0, a `runs_per_task` that is not a whole
    number of at least 1, an `out` that cannot take the outputs (see :func:`check_out`), and
    the study's own problems (ValueError)."""
    _check_task_size("fragility", task_seconds, runs_per_task)
    _check_worker_timeout("fragility", worker_timeout)
    _check_client("fragility", client)
    if worker_cache is not None and str(worker_cache) == "":
        raise ValueError("worker_cache: an empty path (it would be the workers' working directory)")
    path, cache_dir = _paths(study, cache)
    if out is not None:
        # Before anything runs (the Rust core checks again when it writes the outputs).
        check_out(out, cache_dir, "out")
    if command is None:
        command = (
            f"rockbench.fragility({os.fspath(study)!r}, out={None if out is None else os.fspath(out)!r}, "
            f"cache={os.fspath(cache_dir)!r}"
            + ("" if client is None else f", client=Client({_scheduler_address(client)!r}), task_seconds={task_seconds!r}, runs_per_task={runs_per_task!r}")
            + ")"
        )
    if client is None:
        return FragilityResult(fragility_study(path, out, quiet, cache_dir, command))
    wcache = str(Path(worker_cache).resolve()) if worker_cache is not None else str(cache_dir)
    say = None if quiet else (lambda m: print(f"study: {m}", file=sys.stderr))
    stored = [0]

    def store(r: dict[str, Any]) -> None:
        # Every run a task gives, made or found in the workers' cache (which the client's store
        # may not hold: it is elsewhere, or another study filled it); the store keeps new ones.
        runs = r["runs"] if "runs" in r else [(k, text) for k, _, text in r["results"]]
        stored[0] += fragility_store(cache_dir, runs)

    specs = fragility_run_specs(path)
    have = fragility_cache_has(cache_dir, [k for k, _ in specs])
    missing = [(k, s) for (k, s), h in zip(specs, have) if not h]
    _, stripes = _distributed("fragility", str(cache_dir), lambda: distribute(
        client, run_specs_task, missing, (wcache,),
        task_seconds=task_seconds, per_task=runs_per_task, label="stripes", progress=say,
        on_result=store, worker_timeout=worker_timeout, function="fragility",
    ))
    jobs = fragility_ida_jobs(path)
    _, ida = _distributed("fragility", str(cache_dir), lambda: distribute(
        client, ida_task, jobs, (str(path), wcache), probe=1,
        task_seconds=task_seconds, per_task=runs_per_task, label="ida", progress=say,
        on_result=store, worker_timeout=worker_timeout, function="fragility",
    ))
    info = {
        "stripes": stripes,
        "ida": ida,
        "tasks": stripes["tasks"] + ida["tasks"],
        "made": stripes["made"] + ida["made"],
        "stored_by_client": stored[0],
        "already_cached": len(specs) - len(missing),
    }
    # The outputs' counts are those of the assembly, which reads every run from the cache:
    # the command says which of them the cluster made.
    command += (
        f" [on the Dask cluster at {_scheduler_address(client)}: {info['made']} runs made by its "
        f"workers in {info['tasks']} tasks, {info['already_cached']} stripe runs already in the cache]"
    )
    data = fragility_study(path, out, quiet, cache_dir, command)
    return FragilityResult(data, distributed=info)


def _is_study(x: Any) -> bool:
    """A study file: a TOML file whose ``suite`` names the suite's file (no scene has a
    ``suite``; a suite's manifest has a ``[suite]`` table), whatever its name ends in (the
    Rust core reads it as a study all the same)."""
    if not isinstance(x, (str, os.PathLike)) or not os.path.isfile(x):
        return False
    import tomllib

    try:
        with open(x, "rb") as f:
            return isinstance(tomllib.load(f).get("suite"), str)
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError):
        return False


def _check_exists(function: str, path: PathLike) -> str:
    """`path` made absolute (``Path.absolute``: symbolic links and ``..`` kept); a path that
    names nothing is a FileNotFoundError naming it."""
    if str(path) == "":
        raise ValueError(f"{function}: an empty path")
    absolute = str(Path(path).absolute())
    if not os.path.exists(absolute):
        raise FileNotFoundError(errno.ENOENT, f"{function}: no such scene or study file", absolute)
    return absolute


def run_many(
    scenes_or_study: PathLike | Sequence[Any],
    engines: Sequence[str] = ("native",),
    client: Any = None,
    *,
    cache: PathLike | None = None,
    task_seconds: float = TASK_SECONDS,
    runs_per_task: int | None = None,
    worker_timeout: float | None = WORKER_TIMEOUT,
) -> pd.DataFrame:
    """Many runs, locally or on a Dask client, as a DataFrame.

    - A study file: its stripes' runs (scene x engine x record x level) through the run cache;
      one row per run (scene, engine, record, scale, key, made, then the outcome's columns).
      `engines` is ignored: the study names them.
    - Scenes (paths, dicts or Scenes): one run per scene and engine; one row per block.
      `engines` is one engine's name or a sequence of names (a name is not read as its letters).

    Paths (scenes and studies) are made absolute here, on the client, before any run is
    sent out: a Dask worker reads the same file as a local run, whatever its working
    directory. Bad input raises before any run: a path that does not exist
    (FileNotFoundError), a file that is neither a scene nor a study, an engine named twice,
    a bad `client`, `task_seconds`, `runs_per_task` or `worker_timeout` (ValueError /
    TypeError). A run that fails is a row with status ``failed: why``. With a client, a
    scheduler with no workers and a failure of the cluster are raised as by :func:`fragility`
    (:class:`NoWorkersError`, :class:`ClusterError`)."""
    if isinstance(engines, str):
        engines = [engines]
    engines = list(engines)
    _check_task_size("run_many", task_seconds, runs_per_task)
    _check_worker_timeout("run_many", worker_timeout)
    _check_client("run_many", client)
    if isinstance(scenes_or_study, (str, os.PathLike)):
        _check_exists("run_many", scenes_or_study)
    if _is_study(scenes_or_study):
        assert isinstance(scenes_or_study, (str, os.PathLike))
        path, cache_dir = _paths(scenes_or_study, cache)
        specs = fragility_run_specs(path)
        if client is None:
            n = max(1, os.cpu_count() or 1)
            chunks = _chunks(specs, max(1, math.ceil(len(specs) / n)))
            with ThreadPoolExecutor(n) as pool:
                parts = list(pool.map(lambda c: run_specs_task(c, str(cache_dir)), chunks))
            per_item = [r for p in parts for r in p["results"]]
        else:
            per_item, _ = _distributed("run_many", str(cache_dir), lambda: distribute(
                client, run_specs_task, specs, (str(cache_dir),),
                task_seconds=task_seconds, per_task=runs_per_task,
                worker_timeout=worker_timeout, function="run_many",
            ))
        rows = []
        for (key, spec), (k2, made, text) in zip(specs, per_item):
            assert k2 == key, "a run came back under another key"
            s = json.loads(spec)
            row = {
                "scene": s["scene"]["name"],
                "engine": s["engine"],
                "record": s["record_id"],
                "scale": s["scale"],
                "key": key,
                "made": made,
            }
            row.update(outcome_row(json.loads(text)))
            rows.append(row)
        return pd.DataFrame(rows)
    if isinstance(scenes_or_study, (str, os.PathLike, dict, Scene)):
        scenes: list[Any] = [scenes_or_study]
    else:
        scenes = list(scenes_or_study)
    check_engine_names("run_many: engines", engines)
    for e in engines:
        if engines.count(e) > 1:
            raise ValueError(f"run_many: engines: {e} is given twice")
    shipped: list[Any] = []
    for k, s in enumerate(scenes):
        if isinstance(s, Scene):
            shipped.append(s.to_dict())
        elif isinstance(s, (str, os.PathLike)):
            # Absolute (symbolic links kept: the scene's records are read beside the path as
            # given), so a worker with another working directory reads this very file.
            absolute = _check_exists("run_many", s)
            try:
                load_scene(absolute)  # a scene? (ValueError naming the file, before any run)
            except ValueError:
                if _is_study(absolute):
                    raise ValueError(
                        f"run_many: scenes[{k}]: {absolute} is a study; give it alone "
                        "(run_many(study)), not in a list of scenes"
                    ) from None
                raise
            shipped.append(absolute)
        elif isinstance(s, dict):
            # Checked here, and sent with its record paths made absolute (as a Scene's).
            try:
                shipped.append(load_scene(s).to_dict())
            except ValueError as e:
                raise ValueError(f"run_many: scenes[{k}]: {e}") from None
        else:
            raise TypeError(
                f"run_many: scenes[{k}] is a {type(s).__name__}; a scene is a path, a dict or a Scene"
            )
    items = [(s, e) for s in shipped for e in engines]
    if client is None:
        per_item = scenes_task(items)["results"]
    else:
        per_item, _ = _distributed("run_many", None, lambda: distribute(
            client, scenes_task, items, probe=1, task_seconds=task_seconds,
            per_task=runs_per_task, worker_timeout=worker_timeout, function="run_many",
        ))
    return pd.DataFrame([row for rows in per_item for row in rows])


# ---------------------------------------------------------------------------------------------
# The command.


def check_scheduler(address: str, timeout: float) -> str | None:
    """Whether a Dask scheduler answers at `address` within `timeout` s: connect, Dask's
    handshake and one request (``identity``), all within the one deadline (``Client``'s
    timeout bounds only the TCP connection: a server that accepts and never answers held it
    for ever). None if it does, else why not, in a few words (a timeout, a refused
    connection, a server that is not a Dask scheduler: a web server, the dashboard's port, a
    Dask worker)."""
    from distributed.comm.core import connect

    async def ask() -> Any:
        comm = await connect(address, timeout=timeout)  # type: ignore[no-untyped-call]
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    try:
        answer = asyncio.run(asyncio.wait_for(ask(), timeout))
    except TimeoutError:  # asyncio's too (Python 3.11)
        return f"cannot connect: no answer from a Dask scheduler within {timeout:g} s (--timeout)"
    except (OSError, ValueError) as e:
        from distributed.comm.core import CommClosedError

        if isinstance(e, CommClosedError):
            return _one_line(
                f"cannot connect: not a Dask scheduler (it closed the connection without "
                f"Dask's handshake: {e})"
            )
        return _one_line(f"cannot connect: {e}")
    except Exception as e:  # noqa: BLE001  what Dask's protocol makes of other bytes
        return _one_line(
            f"cannot connect: not a Dask scheduler (its answer is not Dask's protocol: "
            f"{type(e).__name__})"
        )
    kind = answer.get("type") if isinstance(answer, dict) else None
    if kind != "Scheduler":
        what = f"a Dask {kind.lower()}" if isinstance(kind, str) else "an unknown Dask server"
        return f"cannot connect: not a Dask scheduler ({what})"
    return None


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m rockbench.study",
        description="Run a fragility study, on a Dask cluster with --scheduler, else here.",
    )
    ap.add_argument("study", help="the study file (TOML)")
    ap.add_argument("--scheduler", help="address of a Dask scheduler (tcp://HOST:8786)")
    ap.add_argument("--out", default="out/fragility", help="output folder (default out/fragility)")
    ap.add_argument("--cache", help="run cache folder, the store of results (default: the study's)")
    ap.add_argument("--worker-cache", help="the workers' cache folder when they do not share --cache")
    ap.add_argument("--task-seconds", type=float, default=TASK_SECONDS, help="target wall time of a task, s")
    ap.add_argument("--runs-per-task", type=int, help="fixed task size (runs; IDA: records)")
    ap.add_argument(
        "--timeout", type=float, default=20.0,
        help="seconds to wait for the scheduler, and for a worker when it has none (default 20)",
    )
    ap.add_argument("--quiet", action="store_true", help="no progress lines")
    a = ap.parse_args(argv)
    if not os.path.isfile(a.study):
        print(f"{a.study}: no such study file", file=sys.stderr)
        return 2
    if not (math.isfinite(a.task_seconds) and a.task_seconds > 0) or (
        a.runs_per_task is not None and a.runs_per_task < 1
    ):
        print("--task-seconds must be positive and --runs-per-task at least 1", file=sys.stderr)
        return 2
    if not (math.isfinite(a.timeout) and 0 < a.timeout <= MAX_TIMEOUT):
        print(f"--timeout: seconds to wait for the scheduler, above 0 and at most {MAX_TIMEOUT:g} (got {a.timeout:g})", file=sys.stderr)
        return 2
    if a.worker_cache == "":
        print("--worker-cache: an empty path (it would be the workers' working directory)", file=sys.stderr)
        return 2
    try:
        fragility_run_specs(a.study)  # read and check everything before connecting or running
        check_out(a.out, _paths(a.study, a.cache)[1], "--out")
    except ValueError as e:
        print(str(e).replace("\n", " "), file=sys.stderr)
        return 2
    client = None
    try:
        if a.scheduler:
            try:
                from distributed import Client
            except ImportError:
                print("--scheduler needs Dask: pip install 'rockbench[dask]'", file=sys.stderr)
                return 2
            why = check_scheduler(a.scheduler, a.timeout)
            if why is not None:
                print(f"--scheduler {a.scheduler}: {why}", file=sys.stderr)
                return 1
            try:
                client = Client(a.scheduler, timeout=f"{a.timeout}s")  # type: ignore[no-untyped-call]
            except Exception as e:  # noqa: BLE001  one line, as for the checks above
                print(_one_line(f"--scheduler {a.scheduler}: cannot connect: {type(e).__name__}: {e}"), file=sys.stderr)
                return 1
        res = fragility(
            a.study, client, out=a.out, cache=a.cache, worker_cache=a.worker_cache,
            task_seconds=a.task_seconds,
            runs_per_task=a.runs_per_task, quiet=a.quiet, worker_timeout=a.timeout,
            command=" ".join(["python", "-m", "rockbench.study", *(sys.argv[1:] if argv is None else argv)]),
        )
    except NoWorkersError as e:
        if e.left:
            print(
                f"--scheduler {a.scheduler}: every worker left and none joined within {e.timeout:g} s; "
                f"the runs finished so far are in the run cache {e.cache}: rerunning the command "
                "resumes from them",
                file=sys.stderr,
            )
        else:
            print(f"--scheduler {a.scheduler}: no workers joined within {e.timeout:g} s", file=sys.stderr)
        return 1
    except ClusterError as e:
        print(
            _one_line(
                f"--scheduler {a.scheduler}: the Dask cluster failed: {e.what}; the runs "
                f"finished so far are in the run cache {e.cache}: rerunning the command "
                "resumes from them"
            ),
            file=sys.stderr,
        )
        # That line says it all: not Dask's own error logs as the client closes (its
        # reconnection to a lost scheduler, cancelled).
        import logging

        logging.disable(logging.CRITICAL)
        return 1
    except (RuntimeError, ValueError, OSError) as e:
        print(f"{a.study}: {e}".replace("\n", " "), file=sys.stderr)
        return 1
    finally:
        if client is not None:
            client.close()  # type: ignore[no-untyped-call]
    c = res.counts
    where = f"on {a.scheduler}" if a.scheduler else "here"
    extra = ""
    if res.distributed:
        d = res.distributed
        extra = f"; {d['made']} runs made in {d['tasks']} tasks {where}"
    print(f"{res.name}: {c['runs']} runs ({c['cached']} from the cache){extra}; wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
