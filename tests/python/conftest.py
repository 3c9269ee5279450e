"""Shared fixtures: scene paths and engine runs done once per session (runs are the slow
part; every test that needs one reads it from here)."""

from __future__ import annotations

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
