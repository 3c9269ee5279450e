"""`rockbench.compare` returns the Rust metrics as a pandas DataFrame (a `Comparison`, with its
notebook HTML); `rockbench.trajectory` gives a run as one."""

from __future__ import annotations

import pandas as pd
import pytest

import rockbench
from conftest import scene_path


def test_compare_returns_the_metrics_as_a_dataframe() -> None:
    df = rockbench.compare(scene_path("housner-slender"), engines=["native", "housner"], reference="housner")
    assert isinstance(df, pd.DataFrame)
    assert list(df.columns) == ["scene", "engine", "block", "metric", "value", "reference", "unit"]
    assert df.attrs["status"] == {"native": "ok", "housner": "ok"}
    first = df[(df.engine == "native") & (df.block == "block") & (df.metric == "impact_time_1")].iloc[0]
    # Native (theta 0.7, dt 1e-3) against Housner's 0.4674 s.
    assert abs(first.reference - 0.4674) < 1e-4
    assert abs(first.value - first.reference) < 1e-3
    rms = df[(df.engine == "native") & (df.block == "block") & (df.metric == "rotation_rms_error")]
    assert 0 < rms.value.iloc[0] < 5e-3


def test_compare_lists_a_skipped_engine_with_its_reason() -> None:
    df = rockbench.compare(scene_path("two-block-free-rocking"), engines=["native", "housner"], reference="native")
    assert df.attrs["status"]["native"] == "ok"
    assert df.attrs["status"]["housner"].startswith("skipped: ")
    assert "single block" in df.attrs["status"]["housner"]
    assert set(df.engine) <= {"native"}


def test_a_comparison_shows_its_status_and_metrics_in_a_notebook() -> None:
    df = rockbench.compare(scene_path("housner-slender"), engines=["native", "housner"], reference="housner")
    assert isinstance(df, rockbench.Comparison)
    page = df._repr_html_()
    assert "native: ok" in page and "housner: ok" in page
    assert "<table" in page and "impact_time_1" in page
    # Selections are plain DataFrames.
    assert type(df[df.engine == "native"]) is pd.DataFrame
    skipped = rockbench.compare(scene_path("two-block-free-rocking"), engines=["housner"], reference="native")
    assert "housner: skipped: " in skipped._repr_html_()


def test_a_run_as_a_dataframe() -> None:
    r = rockbench.run(scene_path("housner-slender"), engine="native")
    df = rockbench.trajectory(r)
    assert list(df.index[:2]) == list(r.t[:2]) and df.index.name == "t"
    assert set(df.columns.get_level_values("field")) == {"x", "z", "phi", "vx", "vz", "omega"}
    assert (df[("block", "phi")].to_numpy() == r.blocks["block"]["phi"]).all()


def test_one_engine_name_is_that_engine_and_no_engine_is_refused() -> None:
    df = rockbench.compare(scene_path("housner-slender"), engines="native", reference="housner")
    assert df.attrs["status"] == {"native": "ok", "housner": "ok"}
    assert set(df.engine) == {"native"}
    with pytest.raises(ValueError, match="--engines: name at least one engine"):
        rockbench.compare(scene_path("housner-slender"), engines=[], reference="housner")


def test_one_override_alone_is_that_override() -> None:
    df = rockbench.compare(
        scene_path("housner-slender"), engines="native", reference="housner", overrides="duration=0.3"
    )
    assert df.attrs["status"] == {"native": "ok", "housner": "ok"}
    # No impact in 0.3 s (the first is at 0.467 s).
    assert "impact_time_1" not in set(df.metric)
