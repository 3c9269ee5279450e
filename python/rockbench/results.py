"""Result objects of the Python API: pandas DataFrames (and an xarray Dataset for the outcome
matrix) built from what the Rust core returns, and their notebook display (``_repr_html_``)."""

from __future__ import annotations

import html
import os
from pathlib import Path
from typing import Any

import pandas as pd  # type: ignore[import-untyped]  # pandas ships no stubs for 3.x

from rockbench._native import OUTCOME_COLUMNS  # outcomes.csv's columns before the limit states


def trajectory(run: Any) -> pd.DataFrame:
    """A run's trajectory (``rockbench.run(...)``) as a DataFrame: one row per sample time
    (index ``t``, s), columns (block, field) for x, z, phi, vx, vz, omega (SI units)."""
    cols = {
        (block, field): values
        for block, fields in run.blocks.items()
        for field, values in fields.items()
    }
    df = pd.DataFrame(cols, index=pd.Index(run.t, name="t"))
    df.columns = pd.MultiIndex.from_tuples(list(cols), names=["block", "field"])
    return df


#: fits.csv's columns (src/fragility/report.rs fits_csv), the columns of ``FragilityResult.fits``.
FIT_COLUMNS = [
    "scene",
    "engine",
    "limit_state",
    "method",
    "theta",
    "beta",
    "theta_lo95",
    "theta_hi95",
    "beta_lo95",
    "beta_hi95",
    "resamples",
    "problem",
]

#: capacities.csv's columns (capacities_csv), the columns of ``FragilityResult.capacities``.
CAPACITY_COLUMNS = [
    "scene",
    "engine",
    "record",
    "pair",
    "limit_state",
    "capacity",
    "censored",
    "resurrection",
    "runs",
]

#: differences.csv's columns (differences_csv), the columns of ``FragilityResult.differences``.
DIFFERENCE_COLUMNS = [
    "scene",
    "limit_state",
    "method",
    "engine",
    "reference",
    "theta_difference",
    "difference_lo95",
    "difference_hi95",
    "theta_ratio",
    "ratio_lo95",
    "ratio_hi95",
    "resamples",
]


def _sliding(overturned: list[bool], values: list[float | None]) -> float:
    """Largest residual sliding of a run, m, as outcomes.csv has it: none (NaN, a blank cell
    in the CSV) when a block overturned (it has no residual position), else the largest of the
    blocks' values (0 without any)."""
    if any(overturned):
        return float("nan")
    return max((float(v) for v in values if v is not None), default=0.0)


def outcome_row(o: dict[str, Any]) -> dict[str, Any]:
    """The scalar columns of one run outcome (the outcome JSON of the Rust core)."""
    return {
        "ran": o["ran"],
        "stop": o["stop"],
        "t_end": o["t_end"],
        "wall_s": o["wall_s"],
        "max_rotation_over_alpha": max(o["rotation"]),
        "overturned": any(o["overturned"]),
        "max_residual_sliding_m": _sliding(o["overturned"], o["sliding"]),
    }


def _interval(ci: Any) -> tuple[Any, Any]:
    return (ci[0], ci[1]) if ci else (None, None)


class Comparison(pd.DataFrame):  # type: ignore[misc]  # pandas is untyped here
    """The metrics of ``rockbench.compare``: a DataFrame (one row per metric, the columns of
    metrics.csv) with each engine's status in ``attrs["status"]``. In a notebook it shows the
    status of every engine, then the metrics as an engine x metric table per block."""

    @property
    def _constructor(self) -> type[pd.DataFrame]:
        # Selections and arithmetic give plain DataFrames.
        frame: type[pd.DataFrame] = pd.DataFrame
        return frame

    @property
    def status(self) -> dict[str, str]:
        return dict(self.attrs.get("status", {}))

    def _repr_html_(self) -> str:
        parts = ["<div><b>rockbench comparison</b>"]
        scenes = sorted(set(self["scene"])) if len(self) else []
        if scenes:
            parts.append(" of " + ", ".join(html.escape(str(s)) for s in scenes))
        parts.append("<ul>")
        for engine, st in self.status.items():
            parts.append(f"<li>{html.escape(engine)}: {html.escape(st)}</li>")
        parts.append("</ul>")
        if len(self):
            table = pd.DataFrame(self).pivot_table(
                index=["block", "engine"], columns="metric", values="value", aggfunc="first"
            )
            parts.append(table.to_html(float_format=lambda x: f"{x:.6g}"))
        parts.append("</div>")
        return "".join(parts)


class FragilityResult:
    """A fragility study's results (the content of fragility.json) as tables.

    - ``outcomes``: one row per run of the outcome matrix (stripes and IDA; the columns of
      outcomes.csv, one boolean column per limit state; ``max_residual_sliding_m`` is NaN for
      a run with an overturned block, where the CSV's cell is blank);
    - ``fits``, ``capacities``, ``differences``: fits.csv, capacities.csv, differences.csv
      (the same columns in the same order, e.g. ``theta_lo95``; a missing value is None or
      NaN where the CSV's cell is blank; values not rounded); a table without rows still has
      its columns;
    - ``to_xarray()``: the stripes as a Dataset with dimensions scene x record x level x engine;
    - ``to_parquet(folder)``: the four tables as Parquet files;
    - ``counts``: runs, runs from the cache, runs made, wall time;
    - ``json``: everything, as the Rust core returned it.
    """

    # The parts of fragility.json the tables read.
    PARTS = ("study", "limit_states", "rows", "fits", "capacities", "differences", "counts")
    # What each part is: a table (a list of objects) or one object.
    KINDS: dict[str, type] = {
        "study": dict,
        "limit_states": list,
        "rows": list,
        "fits": list,
        "capacities": list,
        "differences": list,
        "counts": dict,
    }

    def __init__(self, data: dict[str, Any], distributed: dict[str, Any] | None = None) -> None:
        missing = [k for k in self.PARTS if k not in data] if isinstance(data, dict) else ["all"]
        if missing:
            raise ValueError(
                "FragilityResult: not a fragility study's results (fragility.json): "
                f"missing {', '.join(missing)}"
            )
        wrong = [
            k
            for k, kind in self.KINDS.items()
            if not isinstance(data[k], kind)
            or (kind is list and not all(isinstance(x, dict) for x in data[k]))
        ]
        if not wrong and not all(isinstance(ls.get("name"), str) for ls in data["limit_states"]):
            wrong = ["limit_states (each needs a name)"]
        if wrong:
            raise ValueError(
                "FragilityResult: not a fragility study's results (fragility.json): "
                f"wrong type of {', '.join(wrong)}"
            )
        self.json = data
        self.distributed = distributed
        self.limit_states = [ls["name"] for ls in data["limit_states"]]

    @property
    def name(self) -> str:
        return str(self.json["study"]["name"])

    @property
    def counts(self) -> dict[str, Any]:
        return dict(self.json["counts"])

    @property
    def outcomes(self) -> pd.DataFrame:
        rows = []
        for r in self.json["rows"]:
            row = {k: r[k] for k in ("scene", "engine", "record", "pair", "method", "level", "scale")}
            row.update(outcome_row(r["outcome"]))
            row["cached"] = r["cached"]
            for name, x in zip(self.limit_states, r["exceeded"]):
                row[name] = bool(x)
            rows.append(row)
        return pd.DataFrame(rows, columns=OUTCOME_COLUMNS + self.limit_states)

    @property
    def fits(self) -> pd.DataFrame:
        rows = []
        for f in self.json["fits"]:
            fit = f["fit"] or {}
            tci = _interval(f["theta_ci"])
            bci = _interval(f["beta_ci"])
            rows.append(
                {
                    "scene": f["scene"],
                    "engine": f["engine"],
                    "limit_state": f["limit_state"],
                    "method": f["method"],
                    "theta": fit.get("theta"),
                    "beta": fit.get("beta"),
                    "theta_lo95": tci[0],
                    "theta_hi95": tci[1],
                    "beta_lo95": bci[0],
                    "beta_hi95": bci[1],
                    "resamples": f["resamples"],
                    "problem": f["problem"],
                }
            )
        return pd.DataFrame(rows, columns=FIT_COLUMNS)

    @property
    def capacities(self) -> pd.DataFrame:
        return pd.DataFrame(
            [{k: c[k] for k in CAPACITY_COLUMNS} for c in self.json["capacities"]],
            columns=CAPACITY_COLUMNS,
        )

    @property
    def differences(self) -> pd.DataFrame:
        rows = []
        for d in self.json["differences"]:
            dci = _interval(d["difference_ci"])
            rci = _interval(d["ratio_ci"])
            rows.append(
                {
                    "scene": d["scene"],
                    "limit_state": d["limit_state"],
                    "method": d["method"],
                    "engine": d["engine"],
                    "reference": d["reference"],
                    "theta_difference": d["difference"],
                    "difference_lo95": dci[0],
                    "difference_hi95": dci[1],
                    "theta_ratio": d["ratio"],
                    "ratio_lo95": rci[0],
                    "ratio_hi95": rci[1],
                    "resamples": d["resamples"],
                }
            )
        return pd.DataFrame(rows, columns=DIFFERENCE_COLUMNS)

    def to_xarray(self) -> Any:
        """The stripes' outcome matrix as an ``xarray.Dataset`` with dimensions scene x
        record x level x engine: ``max_rotation_over_alpha``, ``overturned``, ``t_end`` and
        ``exceeded`` (with a ``limit_state`` dimension). Needs ``xarray``
        (``pip install rockbench[dask]`` or xarray itself)."""
        import xarray as xr

        df = self.outcomes
        df = df[df["method"] == "stripes"]
        dims = ["scene", "record", "level", "engine"]
        idx = df.set_index(dims)
        ds = xr.Dataset.from_dataframe(idx[["max_rotation_over_alpha", "overturned", "t_end"]])
        ex = idx[self.limit_states]
        ex.columns = pd.Index(self.limit_states, name="limit_state")
        ds["exceeded"] = xr.DataArray.from_series(ex.stack()).astype(bool)
        ds.attrs["study"] = self.name
        ds.attrs["measure"] = self.json["study"]["intensity"]["measure"]
        return ds

    def to_parquet(self, folder: str | os.PathLike[str]) -> list[Path]:
        """Write outcomes.parquet, fits.parquet, capacities.parquet and differences.parquet
        (pyarrow) to `folder`; returns the paths."""
        out = Path(folder)
        out.mkdir(parents=True, exist_ok=True)
        paths = []
        for name in ("outcomes", "fits", "capacities", "differences"):
            p = out / f"{name}.parquet"
            getattr(self, name).to_parquet(p, engine="pyarrow", index=False)
            paths.append(p)
        return paths

    def _repr_html_(self) -> str:
        c = self.counts
        head = (
            f"<div><b>rockbench fragility study {html.escape(self.name)}</b>: "
            f"{c['runs']} runs ({c['cached']} from the cache, {c.get('made', '?')} made), "
            f"intensity {html.escape(str(self.json['study']['intensity']['measure']))}, "
            f"engines {html.escape(', '.join(self.json['study']['engines']))}"
        )
        if self.distributed:
            d = self.distributed
            head += (
                f"; on Dask: {d['tasks']} tasks, {d['made']} runs made by the workers"
            )
        fits = self.fits[["scene", "engine", "limit_state", "method", "theta", "theta_lo95", "theta_hi95", "beta"]]
        table: str = fits.to_html(index=False, float_format=lambda x: f"{x:.4g}", na_rep="-")
        return head + "</div>" + table

    def __repr__(self) -> str:
        c = self.counts
        return f"FragilityResult({self.name!r}, runs={c['runs']}, fits={len(self.json['fits'])})"
