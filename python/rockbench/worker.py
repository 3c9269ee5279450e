"""Worker process of the external engines.

    python -m rockbench.worker [--early-stop RULE.json] --engine mujoco|pybullet --scene S.json
        --out DIR [--source NAME]

reads a scene (the JSON of ``Scene::to_json()``, or any scene file), runs the engine and
writes ``DIR/trajectory.csv`` (the columns of ``src/trajectory.rs``) and ``DIR/summary.json``
(engine, engine_version, settings, steps, wall_time_s, samples, notes). The Rust harness
(``src/engines/external.rs``) runs it with a timeout and computes events from the trajectory.

``--early-stop`` (fragility studies) names the JSON of an early-stop rule
(``EarlyStopSpec`` in ``src/fragility/early.rs``, checked by ``engines.common.EarlyStop``):
the run ends when a block overturns or the stack is at rest for good, the trajectory ends
at that instant, and the summary's ``early_stop`` is ``{"stop": "overturned" | "at-rest" |
"end", "t": seconds}``.

On failure it writes one line to stderr and exits non-zero: 2 for a bad scene or setting,
3 for a missing Python package (the message names it and how to install it), 4 for an
engine failure (NaN, instability), 1 for anything else.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import sys
import time
import traceback
from typing import Any

ENGINES = ("mujoco", "pybullet")
PACKAGES = {"mujoco": "mujoco", "pybullet": "pybullet"}


class WorkerError(Exception):
    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code


def missing(package: str) -> WorkerError:
    return WorkerError(
        3,
        f"the Python package `{package}` is not installed for {sys.executable}: "
        f"run `make .venv` (or `pip install -r python/requirements.txt`)",
    )


def load(scene_path: str, source: str | None) -> tuple[Any, dict[str, Any]]:
    try:
        import rockbench
    except ImportError as e:
        raise WorkerError(
            3, f"cannot import rockbench ({e}) for {sys.executable}: run `make .venv`"
        ) from None
    try:
        if scene_path.endswith(".json"):
            with open(scene_path) as f:
                spec = json.load(f)
            scene = rockbench.load_scene(spec)
        else:
            scene = rockbench.load_scene(scene_path)
            spec = scene.to_dict()
    except (OSError, json.JSONDecodeError) as e:
        raise WorkerError(2, f"{scene_path}: cannot read the scene: {e}") from None
    except ValueError as e:
        raise WorkerError(2, str(e).replace("<dict>", source or scene_path)) from None
    return scene, spec


def read_early_stop(path: str | None) -> dict[str, Any] | None:
    if path is None:
        return None
    keys = ("rest_speed", "upright", "rest_window", "on_side", "record_end", "gravity",
            "supports", "size", "upright_x", "stack", "load")
    try:
        with open(path) as f:
            rule = json.load(f)
    except (OSError, json.JSONDecodeError) as e:
        raise WorkerError(2, f"{path}: cannot read the early-stop rule: {e}") from None
    if not isinstance(rule, dict) or any(k not in rule for k in keys):
        raise WorkerError(2, f"{path}: an early-stop rule needs {', '.join(keys)}")
    return rule


def run(
    engine: str, scene_path: str, out: str, source: str | None, early_stop: str | None = None
) -> dict[str, Any]:
    rule = read_early_stop(early_stop)
    scene, spec = load(scene_path, source)
    try:
        mod = importlib.import_module(f"rockbench.engines.{engine}_engine")
        getattr(mod, f"import_{engine}")()
    except ModuleNotFoundError as e:
        raise missing(e.name or PACKAGES[engine]) from None

    from rockbench.engines.common import EngineFailure, SettingsError, first_non_finite

    start = time.perf_counter()
    try:
        res = mod.run(scene, spec) if rule is None else mod.run(scene, spec, rule)
    except SettingsError as e:
        raise WorkerError(2, f"{source or scene_path}: {e}") from None
    except (FloatingPointError, EngineFailure) as e:
        raise WorkerError(4, f"{engine}: {e}") from None
    wall = time.perf_counter() - start
    bad = first_non_finite(res.t, res.states)
    if bad is not None:
        raise WorkerError(4, f"{engine}: the state became NaN or infinite at t = {bad:.6g} s")
    os.makedirs(out, exist_ok=True)
    res.write_csv(os.path.join(out, "trajectory.csv"))
    summary = {
        "engine": engine,
        "engine_version": res.engine_version,
        "settings": res.settings,
        "steps": res.steps,
        "wall_time_s": wall,
        "samples": len(res.t),
        "notes": res.notes,
        **res.extra,
    }
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
        f.write("\n")
    return summary


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m rockbench.worker", description=__doc__.split("\n")[0])
    ap.add_argument("--engine", required=True, choices=ENGINES)
    ap.add_argument("--scene", required=True, help="scene JSON (Scene::to_json) or scene file")
    ap.add_argument("--out", required=True, help="output directory")
    ap.add_argument("--source", help="scene file named in error messages")
    ap.add_argument("--early-stop", help="early-stop rule (JSON, src/fragility/early.rs)")
    a = ap.parse_args(argv)
    try:
        run(a.engine, a.scene, a.out, a.source, a.early_stop)
    except WorkerError as e:
        print(str(e).replace("\n", " "), file=sys.stderr)
        return e.code
    except Exception as e:  # noqa: BLE001 - any engine exception is a failed run
        tb = traceback.extract_tb(e.__traceback__)
        where = f" ({tb[-1].filename}:{tb[-1].lineno})" if tb else ""
        print(f"{a.engine}: {type(e).__name__}: {e}{where}".replace("\n", " "), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
