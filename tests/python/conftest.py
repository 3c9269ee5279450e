"""Shared fixtures: scene paths and engine runs done once per session (runs are the slow
part; every test that needs one reads it from here)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

import pytest

import rockbench

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "validation" / "scenes"


def scene_path(name: str) -> str:
    return str(SCENES / f"{name}.toml")


_RUNS: dict[tuple[str, str], rockbench.Run] = {}


def run_once(scene: str, engine: str) -> rockbench.Run:
    """One run of `engine` on a validation scene, shared by the whole session."""
    key = (scene, engine)
    if key not in _RUNS:
        _RUNS[key] = rockbench.run(scene_path(scene), engine=engine)
    return _RUNS[key]


@pytest.fixture
def runs() -> object:
    return run_once


def at2(peak: float, period: float, cycles: float) -> str:
    """A sine burst of `cycles` periods (then 2 s of rest) as a PEER .AT2 file's text."""
    dt = 0.01
    n = int((cycles * period + 2.0) / dt)
    t = np.arange(n) * dt
    a = np.where(t <= cycles * period, peak * np.sin(2 * np.pi * t / period), 0.0)
    lines = [
        "synthetic",
        "sine burst",
        "ACCELERATION TIME SERIES IN UNITS OF G",
        f"NPTS= {n}, DT= {dt:.4f} SEC",
    ]
    for k in range(0, n, 5):
        lines.append("".join(f"{v:15.7E}" for v in a[k : k + 5]))
    return "\n".join(lines) + "\n"


#: Two courses of a running-bond wall (0.6 x 0.25 m) slid by a 0.8 g pulse at friction 0.7:
#: every bed joint at the edge of its cone.
SLIDING_WALL = """name = "sliding-wall-of-five"
duration = 0.005

[[blocks]]
name = "c0b0"
width = 0.6
height = 0.25
x = 0.3

[[blocks]]
name = "c0b1"
width = 0.6
height = 0.25
x = 0.9

[[blocks]]
name = "c0b2"
width = 0.6
height = 0.25
x = 1.5

[[blocks]]
name = "c1b0"
width = 0.6
height = 0.25
x = 0.6

[[blocks]]
name = "c1b1"
width = 0.6
height = 0.25
x = 1.2

[contact]
friction = 0.7

[excitation.horizontal]
kind = "rectangular"
amplitude = 7.848
duration = 0.005
start = 0

[native]
locate_impacts = false
"""

#: The steps of `SLIDING_WALL` whose problems `sliding_wall_problems` writes.
SLIDING_WALL_STEPS = 5


@pytest.fixture(scope="session")
def sliding_wall_problems(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The step problems of `SLIDING_WALL`, written by `examples/wall_problems.rs` (the problem
    each step starts with and the native back-end's solutions of it)."""
    d = tmp_path_factory.mktemp("problems")
    (d / "wall.toml").write_text(SLIDING_WALL)
    subprocess.run(
        ["cargo", "build", "--release", "--quiet", "--example", "wall_problems"],
        cwd=ROOT,
        check=True,
    )
    exe = ROOT / "target" / "release" / "examples" / "wall_problems"
    subprocess.run(
        [str(exe), str(d / "wall.toml"), str(SLIDING_WALL_STEPS), str(d / "steps")],
        cwd=ROOT,
        check=True,
        capture_output=True,
    )
    return d / "steps"
