"""Cross-validation from Python: the metrics of ``rockbench compare`` as a pandas DataFrame
(:class:`rockbench.results.Comparison`)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import pandas as pd  # type: ignore[import-untyped]  # pandas ships no stubs for 3.x

from rockbench._native import Scene, compare_rows
from rockbench.results import Comparison

COLUMNS = ["scene", "engine", "block", "metric", "value", "reference", "unit"]


def compare(
    scene: Scene | str | os.PathLike[str] | dict[str, Any],
    engines: Sequence[str] = ("native", "rapier", "mujoco", "pybullet", "housner"),
    reference: str = "native",
    overrides: Sequence[str] = (),
) -> Comparison:
    """Run ``engines`` on ``scene`` and compare each with ``reference`` (an engine name or a
    trajectory.csv path). Returns one row per metric (long format, the columns of
    metrics.csv); ``df.attrs["status"]`` maps each engine to ``ok``, ``skipped: why`` or
    ``failed: why``. The definitions are the Rust ones (VALIDATION.md). The result is a
    DataFrame that shows the status and an engine x metric table in a notebook. One engine's
    name alone is that engine, and one override alone is that override."""
    names = [engines] if isinstance(engines, str) else list(engines)
    sets = [overrides] if isinstance(overrides, str) else list(overrides)
    rows, status = compare_rows(scene, names, reference, sets)
    df = Comparison(pd.DataFrame(rows, columns=COLUMNS))
    df.attrs["status"] = status
    return df
