"""The fits of `rockbench fragility` against independent implementations: statsmodels'
Binomial GLM with a probit link on ln IM (stripes) and scipy's censored lognormal fit (IDA
capacities). The Rust fitter's parameters are read from the command's fragility.json; the
study is a single block (the `auto` engine: Housner) under six synthetic sine-burst records,
with IDA censored at a level some records never reach."""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import numpy as np
import pytest
import statsmodels.api as sm
from conftest import at2
from scipy import stats

ROOT = Path(__file__).resolve().parents[2]
BIN = ROOT / "target" / "release" / "rockbench"


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> dict:  # type: ignore[type-arg]
    d = tmp_path_factory.mktemp("fragility")
    (d / "block.toml").write_text(
        'name = "block"\nduration = 1.0\n\n[[blocks]]\nname = "block"\nwidth = 0.3\n'
        'height = 1.5\n\n[contact]\nfriction = 2.0\n'
    )
    manifest = '[suite]\nname = "synthetic"\n\n'
    periods = [0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.4]
    for k, p in enumerate(periods):
        (d / f"r{k}.AT2").write_text(at2(0.5, p, 1.5 + 0.25 * (k % 3)))
        manifest += f'[[record]]\nid = "r{k}"\nfile = "r{k}.AT2"\npair = "p{k // 2}"\n\n'
    (d / "suite.toml").write_text(manifest)
    (d / "study.toml").write_text(
        'name = "t"\nscenes = ["block.toml"]\nsuite = "suite.toml"\nengines = ["auto"]\n'
        'cache = "cache"\ntail = 3.0\n\n[intensity]\nmeasure = "pga-ratio"\n'
        "levels = [1.1, 1.3, 1.6, 2.0, 2.5, 3.1, 3.9, 4.9, 6.0]\n\n"
        "[ida]\nstart = 1.1\nfactor = 1.4\ntolerance = 0.02\nmax = 3.5\nfill = 2\n\n"
        "[fit]\nbootstrap = 50\n"
    )
    out = d / "out"
    subprocess.run(
        [str(BIN), "fragility", "--quiet", str(d / "study.toml"), "--out", str(out)],
        check=True,
        capture_output=True,
    )
    return json.loads((out / "fragility.json").read_text())  # type: ignore[no-any-return]


def fit_of(j: dict, ls: str, method: str) -> dict:  # type: ignore[type-arg]
    (f,) = [f for f in j["fits"] if f["limit_state"] == ls and f["method"] == method]
    return f  # type: ignore[no-any-return]


@pytest.mark.parametrize("ls", ["rotation-0.5", "overturn"])
def test_stripes_match_statsmodels_probit_glm(study: dict, ls: str) -> None:  # type: ignore[type-arg]
    k = [x["name"] for x in study["limit_states"]].index(ls)
    levels = sorted({r["level"] for r in study["rows"] if r["method"] == "stripes"})
    n, z = [], []
    for lv in levels:
        at = [r for r in study["rows"] if r["method"] == "stripes" and r["level"] == lv]
        n.append(len(at))
        z.append(sum(r["exceeded"][k] for r in at))
    assert 0 < sum(z) < sum(n), (n, z)
    counts = np.column_stack([z, np.array(n) - np.array(z)])
    x = sm.add_constant(np.log(levels))
    glm = sm.GLM(counts, x, family=sm.families.Binomial(link=sm.families.links.Probit()))
    b0, b1 = glm.fit(tol=1e-12).params
    theta, beta = math.exp(-b0 / b1), 1.0 / b1
    f = fit_of(study, ls, "stripes")["fit"]
    assert f["theta"] == pytest.approx(theta, rel=1e-6)
    assert f["beta"] == pytest.approx(beta, rel=1e-6)


@pytest.mark.parametrize("ls", ["rotation-0.5", "overturn"])
def test_ida_matches_scipy_censored_lognormal(study: dict, ls: str) -> None:  # type: ignore[type-arg]
    caps = [c for c in study["capacities"] if c["limit_state"] == ls]
    assert len(caps) == 10
    unc = [c["capacity"] for c in caps if not c["censored"]]
    cen = [c["capacity"] for c in caps if c["censored"]]
    assert unc, "no record reaches the limit state"
    f = fit_of(study, ls, "ida")["fit"]
    if cen:
        data = stats.CensoredData(uncensored=unc, right=cen)
        s, _, scale = stats.lognorm.fit(data, floc=0)
        # scipy's optimiser stops at its own tolerance: compare the log-likelihoods too.
        assert f["theta"] == pytest.approx(scale, rel=2e-3)
        assert f["beta"] == pytest.approx(s, rel=2e-3)
        ll = lambda sig, sc: stats.lognorm.logpdf(unc, sig, scale=sc).sum() + stats.lognorm.logsf(  # noqa: E731
            cen, sig, scale=sc
        ).sum()
        assert ll(f["beta"], f["theta"]) >= ll(s, scale) - 1e-9
    else:
        s, _, scale = stats.lognorm.fit(unc, floc=0)
        assert f["theta"] == pytest.approx(scale, rel=1e-9)
        assert f["beta"] == pytest.approx(s, rel=1e-9)


def test_the_study_censors_some_records(study: dict) -> None:  # type: ignore[type-arg]
    caps = [c for c in study["capacities"] if c["limit_state"] == "overturn"]
    assert any(c["censored"] for c in caps) and not all(c["censored"] for c in caps)


def test_bindings_run_the_same_unit_of_work(tmp_path: Path, study: dict) -> None:  # type: ignore[type-arg]
    """`fragility_run_specs` lists the stripes' runs as JSON specs with their cache keys and
    `fragility_run` runs one: the outcome is the CLI's for the same record and level."""
    import rockbench

    # The cache keys hold the hash of the program's sources: an extension built from other
    # sources than the CLI that made the study (a `.venv` older than the checkout) finds none of
    # its runs.
    cli = study["rockbench_source_hash"]
    assert cli == rockbench.__source_hash__, (
        f"the extension (sources {rockbench.__source_hash__}) was built from other sources than "
        f"{BIN} (sources {cli}): `make test` builds both"
    )
    path = Path(study["study_file"])
    specs = rockbench.fragility_run_specs(path)
    levels = study["study"]["intensity"]["levels"]
    assert len(specs) == 10 * len(levels)
    keys = {k for k, _ in specs}
    assert len(keys) == len(specs)
    key, spec = specs[7]
    s = json.loads(spec)
    out = json.loads(rockbench.fragility_run(spec))
    (row,) = [
        r
        for r in study["rows"]
        if r["method"] == "stripes" and r["record"] == s["record_id"] and r["scale"] == s["scale"]
    ]
    for f in ["rotation", "overturned", "sliding", "stop", "ran"]:
        assert out[f] == row["outcome"][f], f
    j = rockbench.fragility_study(path, out=tmp_path / "o")
    assert j["counts"]["cached"] == j["counts"]["runs"]
    assert j["fits"] == study["fits"]
    with pytest.raises(ValueError, match="intensity.levels"):
        bad = tmp_path / "bad.toml"
        bad.write_text(path.read_text().replace("levels = [1.1,", "levels = [0,"))
        (tmp_path / "block.toml").write_text((path.parent / "block.toml").read_text())
        rockbench.fragility_study(bad)


def test_specs_keys_and_cache_entries_from_elsewhere_are_checked(
    tmp_path: Path,
    study: dict,  # type: ignore[type-arg]
) -> None:
    """A run spec, a run key or a cache entry may come from another process (a Dask task, a
    shared folder): a spec's scene is checked as a scene file is, a string that is not a run key
    has no entry, and an entry that cannot be its run's (another block count) is run again."""
    import rockbench

    path = Path(study["study_file"])
    key, spec = rockbench.fragility_run_specs(path)[3]
    s = json.loads(spec)
    s["scene"]["blocks"] = []
    with pytest.raises(ValueError, match="blocks"):
        rockbench.fragility_run(json.dumps(s))
    s = json.loads(spec)
    s["scene"]["gravity"] = 0.0
    with pytest.raises(ValueError, match="gravity"):
        rockbench.fragility_run(json.dumps(s))
    from rockbench import _native

    cache = tmp_path / "cache"
    assert _native.fragility_cache_has(str(cache), ["a\u00e90000", "", key]) == [False] * 3
    good = json.loads(rockbench.fragility_run(spec))
    # An outcome no run can have is refused before it is stored.
    n = len(good["rotation"])
    for bad, says in (
        (dict(good, rotation=[], overturned=[], sliding=[]), "one finite value for each block"),
        (dict(good, rotation=[-1.0] * n), r"rotation\[0\] = -1 is negative"),
        (dict(good, overturned=[True] * n, sliding=[0.0] * n), "overturned and has no residual"),
        (dict(good, t_end=-1.0), "t_end = -1 is not a time"),
    ):
        with pytest.raises(ValueError, match=f"run {key}: outcome: .*{says}"):
            _native.fragility_store(str(cache), [(key, json.dumps(bad))])
    assert not cache.exists(), "a refused outcome was stored"
    for call in (
        lambda: _native.fragility_store("", [(key, json.dumps(good))]),
        lambda: _native.fragility_cache_has("", [key]),
        lambda: _native.fragility_run_batch([spec], ""),
    ):
        with pytest.raises(ValueError, match="cache: an empty path"):
            call()
    with pytest.raises(ValueError, match="unknown engine `bogus`"):
        rockbench.fragility_is_python_worker("bogus")
    # An outcome that can be a run's, but not this one's (two blocks): stored, then run again.
    wrong = {k: v * 2 if isinstance(v, list) else v for k, v in good.items()}
    assert _native.fragility_store(str(cache), [(key, json.dumps(wrong))]) == 1
    ((k, made, text),) = _native.fragility_run_batch([spec], str(cache))
    assert k == key and made, "an entry of another block count was taken as the run"
    assert json.loads(text)["rotation"] == good["rotation"]
    ((_, made, _),) = _native.fragility_run_batch([spec], str(cache))
    assert not made, "the run made again was not stored"


def test_ida_jobs_from_elsewhere_are_checked_against_their_study(
    tmp_path: Path,
    study: dict,  # type: ignore[type-arg]
) -> None:
    """IDA jobs handed to a worker name a scene, an engine and a record of a study with an
    [ida] table; others are a ValueError before any run, not an empty answer."""
    from rockbench import _native

    path = Path(study["study_file"])
    ((si, engine, record), *_) = _native.fragility_ida_jobs(path)
    cache = str(tmp_path / "cache")
    for job, says in (
        ((si, "rapier", record), "is not in the study"),
        ((si + 5, engine, record), "is not in the study"),
        ((si, engine, "nowhere"), "no such record in the suite"),
    ):
        with pytest.raises(ValueError, match=f"fragility_ida_batch: IDA job .*{says}"):
            _native.fragility_ida_batch(path, [job], cache)
    for f in ("block.toml", "suite.toml") + tuple(f"r{k}.AT2" for k in range(10)):
        (tmp_path / f).write_text((path.parent / f).read_text())
    no_ida = tmp_path / "study.toml"
    no_ida.write_text(path.read_text().split("[ida]")[0] + "[fit]\nbootstrap = 50\n")
    assert _native.fragility_ida_jobs(no_ida) == []
    with pytest.raises(ValueError, match=r"1 IDA jobs given, but the study has no \[ida\] table"):
        _native.fragility_ida_batch(no_ida, [(si, engine, record)], cache)
    assert not (tmp_path / "cache").exists()
