"""The installed package at work, outside the source tree (run by `make wheel-test` in a fresh
virtual environment where the wheel was installed with `pip install`): import, a run, a
comparison, a small fragility study here and on a one-process Dask cluster, the results as
DataFrames, an xarray Dataset and notebook HTML. Exits non-zero on the first failure."""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

import pandas as pd

import rockbench

SCENE = {
    "name": "slender",
    "duration": 2.0,
    "blocks": [{"name": "block", "width": 0.2, "height": 1.0}],
    "initial": {"tilt": 0.05},
    "contact": {"friction": 2.0},
}


def at2(path: Path, peak: float, period: float) -> None:
    dt, n = 0.01, int((2 * period + 1.0) / 0.01)
    a = [peak * math.sin(2 * math.pi * k * dt / period) if k * dt <= 2 * period else 0.0 for k in range(n)]
    lines = ["synthetic", "sine burst", "ACCELERATION TIME SERIES IN UNITS OF G", f"NPTS= {n}, DT= {dt:.4f} SEC"]
    lines += ["".join(f"{v:15.7E}" for v in a[k : k + 5]) for k in range(0, n, 5)]
    path.write_text("\n".join(lines) + "\n")


def main() -> int:
    src = Path(rockbench.__file__).resolve()
    assert "site-packages" in str(src), f"rockbench imported from {src}, not the installed wheel"
    r = rockbench.run(SCENE, engine="native")
    assert r.t[-1] > 1.9 and len(r.blocks["block"]["phi"]) == len(r.t)
    traj = rockbench.trajectory(r)
    assert isinstance(traj, pd.DataFrame) and len(traj) == len(r.t)
    assert traj[("block", "phi")].iloc[0] == r.blocks["block"]["phi"][0]
    c = rockbench.compare(SCENE, engines=["native", "housner"], reference="housner")
    assert isinstance(c, pd.DataFrame) and c.status == {"native": "ok", "housner": "ok"}, c.status
    assert "<table" in c._repr_html_()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        (d / "block.toml").write_text(
            'name = "block"\nduration = 1.0\n\n[[blocks]]\nname = "block"\nwidth = 0.3\nheight = 1.5\n\n'
            "[contact]\nfriction = 2.0\n"
        )
        manifest = '[suite]\nname = "bursts"\n\n'
        for k in range(4):
            at2(d / f"r{k}.AT2", 0.5, 0.4 + 0.15 * k)
            manifest += f'[[record]]\nid = "r{k}"\nfile = "r{k}.AT2"\npair = "p{k // 2}"\n\n'
        (d / "suite.toml").write_text(manifest)
        (d / "study.toml").write_text(
            'name = "smoke"\nscenes = ["block.toml"]\nsuite = "suite.toml"\nengines = ["native"]\n'
            'cache = "cache"\ntail = 1.0\n\n[intensity]\nmeasure = "pga-ratio"\nlevels = [1.2, 2.0, 3.5]\n\n'
            '[fit]\nbootstrap = 20\n\n[[limit_state]]\nname = "overturn"\nkind = "overturn"\n'
        )
        res = rockbench.fragility(d / "study.toml", out=d / "out")
        assert res.counts["made"] == 12 and (d / "out" / "report.html").exists()
        assert isinstance(res.outcomes, pd.DataFrame) and len(res.outcomes) == 12
        assert isinstance(res.fits, pd.DataFrame) and list(res.fits["method"]) == ["stripes"]
        ds = res.to_xarray()
        assert dict(ds.sizes) == {"scene": 1, "record": 4, "level": 3, "engine": 1, "limit_state": 1}
        assert "smoke" in res._repr_html_()
        from distributed import Client, LocalCluster

        with LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cl, Client(cl) as client:
            again = rockbench.fragility(d / "study.toml", client, cache=d / "cache2")
        assert again.distributed is not None and again.distributed["made"] == 12
        assert again.json["fits"] == res.json["fits"]
        table = rockbench.run_many(d / "study.toml")
        assert len(table) == 12 and not table["made"].any()
    print(f"rockbench {rockbench.__version__} from {src.parent}: run, compare, fragility (local and Dask) ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
