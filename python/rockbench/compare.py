"""Cross-validation from Python: the metrics of ``rockbench compare`` as a pandas DataFrame."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import pandas as pd  # type: ignore[import-untyped]  # pandas ships no stubs for 3.x

from rockbench._native import Scene, compare_rows

COLUMNS = ["scene", "engine", "block", "metric", "value", "reference", "unit"]


def compare(
    scene: Scene | str | os.PathLike[str] | dict[str, Any],
    engines: Sequence[str] = ("native", "rapier", "mujoco", "pybullet", "housner"),
    reference: str = "native",
    overrides: Sequence[str] = (),
) -> pd.DataFrame:
    """Run ``engines`` on ``scene`` and compare each with ``reference`` (an engine name or a
    trajectory.csv path). Returns one row per metric (long format, the columns of
    metrics.csv); ``df.attrs["status"]`` maps each engine to ``ok``, ``skipped: why`` or
    ``failed: why``. The definitions are the Rust ones (VALIDATION.md)."""
    rows, status = compare_rows(scene, list(engines), reference, list(overrides))
    df = pd.DataFrame(rows, columns=COLUMNS)
    df.attrs["status"] = status
    return df
