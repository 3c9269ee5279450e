"""Throughput of a fragility study on a Dask LocalCluster of 1 and 2 worker processes, and the
scheduler's overhead per task (docs/cluster.md).

    .venv/bin/python benches/dask_scaling.py [STUDY.toml] [--out out/bench/dask-scaling.json]

For each worker count the study's stripes run from an empty run cache (runs/s = runs made /
wall time of the distributed phase); the per-task overhead is measured twice: from the study
(wall x worker threads - summed work of the tasks, over the tasks) and with 400 empty tasks
submitted together (wall time per task: the scheduler's and the workers' cost of a task). Prints one JSON document and writes it to --out.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

from distributed import Client, LocalCluster

import rockbench
from rockbench.studies import distribute


def nothing(batch: list[int]) -> dict[str, object]:
    return {"made": 0, "work_s": 0.0, "pid": os.getpid(), "results": batch}


def empty_tasks(client: Client, n: int) -> float:
    """Seconds per task of `n` empty tasks, submitted together, on the client's workers."""
    start = time.perf_counter()
    futures = [client.submit(nothing, [i], pure=False) for i in range(n)]
    client.gather(futures)
    return (time.perf_counter() - start) / n


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("study", nargs="?", default="validation/studies/statue-demo.toml")
    ap.add_argument("--out", default="out/bench/dask-scaling.json")
    ap.add_argument("--task-seconds", type=float, default=2.0)
    a = ap.parse_args()
    study = Path(a.study).resolve()
    specs = rockbench.fragility_run_specs(study)
    report: dict[str, object] = {
        "study": str(study),
        "runs": len(specs),
        "cpus": os.cpu_count(),
        "load_before": os.getloadavg(),
        "task_seconds": a.task_seconds,
    }
    tmp = Path(tempfile.mkdtemp(prefix="rockbench-scaling-"))
    try:
        # The Rust core alone, on every core of this machine (rayon), for reference.
        start = time.perf_counter()
        loc = rockbench.fragility(study, cache=tmp / "local")
        report["local_rayon"] = {
            "runs": loc.counts["made"],
            "wall_s": time.perf_counter() - start,
            "runs_per_s": loc.counts["made"] / (time.perf_counter() - start),
            "run_s_mean": loc.counts["run_wall_s"] / max(1, loc.counts["made"]),
        }
        sizes = [p.stat().st_size for p in (tmp / "local").glob("*/*.json")]
        report["cache_entry_bytes"] = statistics.mean(sizes)
        for n in (1, 2):
            with LocalCluster(
                n_workers=n, processes=True, threads_per_worker=1, dashboard_address=None
            ) as cluster, Client(cluster) as client:
                cache = tmp / f"w{n}"
                from rockbench.studies import run_specs_task

                _, st = distribute(
                    client, run_specs_task, specs, (str(cache),), task_seconds=a.task_seconds, label="bench"
                )
                overhead = (st["wall_s"] * st["slots"] - st["work_s"]) / st["tasks"]
                report[f"workers_{n}"] = {
                    "runs": st["made"],
                    "tasks": st["tasks"],
                    "task_size": st["task_size"],
                    "wall_s": st["wall_s"],
                    "work_s": st["work_s"],
                    "runs_per_s": st["made"] / st["wall_s"],
                    "run_s_mean": st["work_s"] / st["made"],
                    "task_s_mean": st["work_s"] / st["tasks"],
                    "idle_or_overhead_per_task_s": overhead,
                    "overhead_fraction": 1 - st["work_s"] / (st["wall_s"] * st["slots"]),
                    "load": os.getloadavg(),
                }
                empty_tasks(client, 50)  # warm up
                report[f"workers_{n}"]["empty_task_s"] = empty_tasks(client, 400)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    w1, w2 = report["workers_1"], report["workers_2"]
    assert isinstance(w1, dict) and isinstance(w2, dict)
    report["speedup_2_over_1"] = w2["runs_per_s"] / w1["runs_per_s"]
    text = json.dumps(report, indent=2)
    print(text)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
