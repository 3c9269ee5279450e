"""Shared fixtures: scene paths and engine runs done once per session (runs are the slow
part; every test that needs one reads it from here)."""

from __future__ import annotations

from pathlib import Path

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
