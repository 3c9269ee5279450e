"""The bounds of the MuJoCo, PyBullet and Siconos settings (each bad value refused with one line
naming ``table.field``, the bound and the value) and the last step of a run whose duration is
not a whole number of steps (shorter, so that the last sample is at the duration)."""

from __future__ import annotations

import importlib
import json
import math
import os
import re
import subprocess
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest

import rockbench
from conftest import ROOT, scene_path
from rockbench.engines import common, mujoco_engine, pybullet_engine
from rockbench.engines.common import SettingsError

ENGINES = {"mujoco": mujoco_engine, "pybullet": pybullet_engine}


def scene_dict(name: str = "housner-square", duration: float = 0.05, **tables: Any) -> dict[str, Any]:
    d = rockbench.load_scene(scene_path(name)).to_dict()
    d["duration"] = duration
    d.update(tables)
    return d


@pytest.fixture
def siconos_worker(monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    """The Siconos worker's module (importing it sets OPENBLAS_NUM_THREADS; kept to the test)."""
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", os.environ.get("OPENBLAS_NUM_THREADS", "1"))
    return importlib.import_module("rockbench.siconos_worker")


def run_in_process(engine: str, d: dict[str, Any]) -> common.EngineResult:
    """The engine's ``run`` in this process (the settings are checked before the engine is
    imported, so a refusal costs no simulation)."""
    scene = rockbench.load_scene(d)
    result: common.EngineResult = ENGINES[engine].run(scene, scene.to_dict())
    return result


def refused(engine: str, table: dict[str, Any], pattern: str, **scene: Any) -> str:
    """The one-line message of a refused ``[engine]`` table; it names the field and matches."""
    with pytest.raises(SettingsError) as e:
        run_in_process(engine, {**scene_dict(**scene), engine: table})
    msg = str(e.value)
    assert "\n" not in msg and re.search(pattern, msg), msg
    return msg


# 1. The out-of-plane depth, relative to the scene's blocks (housner-square: 1.25 m square).


@pytest.mark.parametrize(
    "engine, depth, bounds",
    [
        ("mujoco", 1e-300, r"0\.0125 m\) to 100 x the largest \(125 m\)"),
        ("mujoco", 1e6, r"0\.0125 m\) to 100 x the largest \(125 m\)"),
        ("pybullet", 1e-6, r"0\.0125 m\) to 50 x it \(62\.5 m\)"),
        ("pybullet", 100.0, r"0\.0125 m\) to 50 x it \(62\.5 m\)"),
    ],
)
def test_a_depth_out_of_proportion_with_the_blocks_is_refused(engine: str, depth: float, bounds: str) -> None:
    refused(
        engine,
        {"depth": depth},
        rf"^{engine}\.depth: must be from 0\.01 x the smallest block dimension \({bounds} "
        rf"\(got {re.escape(repr(depth))}\)$",
    )


def test_the_default_depth_and_ground_follow_the_scene_where_a_given_one_is_refused() -> None:
    d = scene_dict()
    d["blocks"][0]["width"] = 0.01  # 50 x 0.01 m = 0.5 m < the default 1 m
    d["initial"] = {"tilt": 0.001}
    d["duration"] = 0.05
    with pytest.raises(SettingsError, match=r"^pybullet\.depth: .* \(got 1\.0\)$"):
        run_in_process("pybullet", {**d, "pybullet": {"depth": 1.0}})
    r = run_in_process("pybullet", d)
    assert r.settings["depth"] == 0.5 and np.isfinite(r.states).all()
    # A block 60 m from x = 0: the default ground (50 m) grows to reach it, a given one is refused.
    far = scene_dict()
    far["blocks"][0]["offset"] = 60.0
    far["duration"] = 0.05
    r = run_in_process("pybullet", far)
    assert r.settings["ground_half_size"] > 60.0 and r.states[-1, 0, 1] > 0.6
    with pytest.raises(SettingsError, match=r"^pybullet\.ground_half_size: .* \(got 50\.0\)$"):
        run_in_process("pybullet", {**far, "pybullet": {"ground_half_size": 50.0}})
    for engine in ("mujoco", "pybullet"):
        assert run_in_process(engine, scene_dict(duration=0.05)).settings["depth"] == 1.0


def test_a_depth_within_the_bounds_gives_the_same_planar_motion() -> None:
    runs = [
        run_in_process("pybullet", scene_dict(pybullet={"depth": x})) for x in (0.0125, 1.0, 62.5)
    ]
    for r in runs[1:]:
        np.testing.assert_allclose(r.states, runs[0].states, rtol=0, atol=1e-9)


# 2. PyBullet's ground under the blocks.


def test_a_ground_smaller_than_the_blocks_reach_is_refused() -> None:
    scene = rockbench.load_scene(scene_dict())
    b = scene.layout()[0]
    # The corners of the 1.25 m square block, tilted 0.15 rad on one of its bottom corners.
    c, s = math.cos(b["phi"]), math.sin(b["phi"])
    corners = [b["x"] + c * dx - s * dz for dx in (-0.625, 0.625) for dz in (-0.625, 0.625)]
    far = max(abs(x) for x in corners)
    assert far == common.farthest_corner(scene.to_dict(), scene.layout()) and far > 0.625
    need = far + 1.25
    refused(
        "pybullet",
        {"ground_half_size": 1e-9},
        rf"^pybullet\.ground_half_size: must be at least the farthest block corner from x = 0 "
        rf"\({far:.6g} m\) plus the largest block dimension \(1\.25 m\), {need:.6g} m "
        r"\(got 1e-09\)$",
    )
    with pytest.raises(SettingsError, match=r"ground_half_size"):
        run_in_process("pybullet", scene_dict(pybullet={"ground_half_size": need * (1 - 1e-9)}))
    r = run_in_process("pybullet", scene_dict(pybullet={"ground_half_size": need}))
    assert np.isfinite(r.states).all() and r.states[-1, 0, 1] > 0.6


# 3. Solver tolerances are relative residuals, below 1.


@pytest.mark.parametrize("value", [1e300, 1, 1.0, -1e-8])
def test_a_mujoco_tolerance_of_one_or_more_is_refused(value: float) -> None:
    refused(
        "mujoco",
        {"tolerance": value},
        rf"^mujoco\.tolerance: must be a relative residual, >= 0 and < 1 \(got {re.escape(repr(value))}\)$",
    )


def test_a_mujoco_tolerance_of_zero_runs_every_iteration() -> None:
    r = run_in_process("mujoco", scene_dict(duration=0.01, mujoco={"tolerance": 0}))
    assert np.isfinite(r.states).all()


@pytest.mark.parametrize("value", [1e300, 1.0, 0, -1e-12])
def test_a_siconos_tolerance_outside_zero_to_one_is_refused(value: float, siconos_worker: ModuleType) -> None:
    with pytest.raises(siconos_worker.WorkerError) as e:
        siconos_worker.read_settings({"tolerance": value})
    assert e.value.code == 2
    assert str(e.value) == f"siconos.tolerance: must be a relative residual, > 0 and < 1 (got {value!r})"


# 4. MuJoCo's solref and solimp within the ranges MuJoCo uses them in.


def test_the_impedance_range_is_mujocos() -> None:
    mujoco = mujoco_engine.import_mujoco()
    assert (mujoco_engine.MIN_IMPEDANCE, mujoco_engine.MAX_IMPEDANCE) == (mujoco.mjMINIMP, mujoco.mjMAXIMP)


@pytest.mark.parametrize(
    "solref, why",
    [
        ([1e-6, 1.0], r"the time constant must be at least 2 x mujoco\.timestep \(0\.0002 s; "),
        ([1.999e-4, 1.0], r"the time constant must be at least 2 x mujoco\.timestep \(0\.0002 s; "),
        ([0.0003, -1.0], r"time constant and damping ratio must both be > 0 "),
        ([0.0003, 0.0], r"time constant and damping ratio must both be > 0 "),
        ([-100.0, -10.0], r"time constant and damping ratio must both be > 0 "),
    ],
)
def test_a_bad_solref_is_refused(solref: list[float], why: str) -> None:
    refused("mujoco", {"solref": solref}, rf"^mujoco\.solref: {why}.*\(got {re.escape(repr(solref))}\)$")


def test_the_default_solref_follows_mujocos_floor_of_two_steps() -> None:
    """At a timestep of 1e-3 s MuJoCo raises the default 3e-4 s to 2e-3 s: the run records
    the time constant it used; a solref given at exactly 2 x timestep is accepted."""
    r = run_in_process("mujoco", scene_dict(mujoco={"timestep": 1e-3}))
    assert r.settings["solref"] == [2e-3, 1.0]
    r = run_in_process("mujoco", scene_dict(mujoco={"timestep": 1e-3, "solref": [2e-3, 1.0]}))
    assert r.settings["solref"] == [2e-3, 1.0]
    assert run_in_process("mujoco", scene_dict()).settings["solref"] == [3e-4, 1.0]


@pytest.mark.parametrize(
    "solimp, why",
    [
        ([1.5, 2.0, 0.001], r"dmin must be in \[0\.0001, 0\.9999\]"),
        ([0.0, 0.9, 0.001], r"dmin must be in \[0\.0001, 0\.9999\]"),
        ([0.9, 1.0, 0.001], r"dmax must be in \[0\.0001, 0\.9999\]"),
        ([0.9, 0.95, 0.0], r"width must be > 0 m"),
        ([0.9, 0.95, -1.0], r"width must be > 0 m"),
        ([0.9, 0.95, 0.001, 1.0, 2.0], r"midpoint must be in \[0\.0001, 0\.9999\]"),
        ([0.9, 0.95, 0.001, 0.0, 2.0], r"midpoint must be in \[0\.0001, 0\.9999\]"),
        ([0.9, 0.95, 0.001, 0.5, 0.5], r"power must be >= 1"),
    ],
)
def test_a_solimp_outside_mujocos_ranges_is_refused(solimp: list[float], why: str) -> None:
    refused("mujoco", {"solimp": solimp}, rf"^mujoco\.solimp: {why}.*\(got {re.escape(repr(solimp))}\)$")


# 5. Counts the libraries hold (a C int) and at most 1e9 internal steps.


@pytest.mark.parametrize(
    "engine, field",
    [("pybullet", "num_sub_steps"), ("pybullet", "num_solver_iterations"), ("mujoco", "iterations")],
)
def test_a_count_larger_than_a_c_int_is_refused(engine: str, field: str) -> None:
    for value in (2**31, 2**40):
        refused(
            engine,
            {field: value},
            rf"^{engine}\.{field}: must be a whole number from 1 to 2147483647 \(a C int\) \(got {value}\)$",
        )


def test_a_siconos_iteration_count_larger_than_a_c_int_is_refused(siconos_worker: ModuleType) -> None:
    assert siconos_worker.read_settings({"iterations": 2**31 - 1})["iterations"] == 2**31 - 1
    with pytest.raises(siconos_worker.WorkerError) as e:
        siconos_worker.read_settings({"iterations": 2**40})
    assert str(e.value) == (
        f"siconos.iterations: must be a whole number from 1 to 2147483647 (a C int) (got {2**40})"
    )


def test_pybullet_sub_steps_past_a_billion_internal_steps_are_refused() -> None:
    # 50 calls of 1e-3 s.
    refused(
        "pybullet",
        {"num_sub_steps": 20_000_001},
        r"^pybullet\.num_sub_steps: 50 calls x 20000001 sub-steps = 1\.000000e\+09 internal "
        r"steps; at most 1\.000000e\+09 are allowed \(got 20000001\)$",
    )


def test_a_bad_count_through_the_harness_is_one_line_naming_the_field() -> None:
    d = scene_dict(pybullet={"num_solver_iterations": 2**40})
    with pytest.raises(ValueError) as e:
        rockbench.run(d, engine="pybullet")
    msg = str(e.value)
    assert "\n" not in msg, msg
    assert "pybullet.num_solver_iterations: must be a whole number from 1 to 2147483647" in msg, msg


# 6. A step longer than the time scale of the fastest block, as the harness refuses it.


@pytest.mark.parametrize("engine, field", [("mujoco", "timestep"), ("pybullet", "fixed_time_step")])
def test_a_step_longer_than_the_fastest_blocks_time_scale_is_refused_as_the_harness_refuses_it(
    engine: str, field: str
) -> None:
    # housner-square: B = H = 1.25 m, R = 0.8839 m, p = sqrt(3 g / 4R) = 2.885 1/s.
    msg = refused(
        engine,
        {field: 0.4},
        rf"^{engine}\.{field}: 0\.4 s is longer than the time scale 1/p = 0\.3466 s of block `block` "
        r"\(p = sqrt\(3 g / 4R\)\): a step would step over its motion \(ms given for s\?\)$",
        duration=2.0,
    )
    with pytest.raises(ValueError) as e:
        rockbench.load_scene({**scene_dict(duration=2.0), "native": {"dt": 0.4}})
    assert str(e.value).endswith("native.dt: " + msg.removeprefix(f"{engine}.{field}: ")), e.value
    common.check_step_resolves(scene_dict(duration=2.0), 0.34, f"{engine}.{field}")


# 7. The last step ends at the duration.


def test_the_time_grid_ends_at_the_duration() -> None:
    g = common.time_grid(0.30006, 1e-3, 1e-4, None, "s")
    assert g.n_steps == 3001 and g.partial
    assert math.isclose(g.last_step, 0.6e-4, rel_tol=1e-9)
    assert g.sample_times[-1] == 0.30006 and g.sample_times[-2] == 3000 * 1e-4
    # A whole number of steps (to 1e-9 of a step): the samples of k * step, as before.
    for duration in (0.3, 0.3 + 1e-15, 0.3 - 1e-15, 4.0):
        g = common.time_grid(duration, 7e-4, 1e-4, 1e-3, "s")
        n = max(1, round(duration / 1e-4))
        assert not g.partial and g.n_steps == n
        old = np.array(list(range(0, n, 7)) + [n], dtype=float) * 1e-4
        assert np.array_equal(g.sample_times, old)
        assert g.boundaries == sorted(set(range(0, n, 7)) | set(range(0, n, 10)) | {n})


def at_duration_is_between_its_neighbours(run: Any, ref: Any, duration: float) -> None:
    """The sample at ``duration`` is the linear interpolation of the reference's samples at the
    whole steps around it, to 1 % of the change over that step (a step of the run's engine: its
    state within the step is smooth in free rocking)."""
    i = int(np.searchsorted(ref.t, duration))
    t0, t1 = ref.t[i - 1], ref.t[i]
    assert t0 < duration < t1
    w = (duration - t0) / (t1 - t0)
    for name in run.blocks:
        for f in common.FIELDS:
            a = ref.blocks[name][f]
            want = a[i - 1] + w * (a[i] - a[i - 1])
            got = run.blocks[name][f][-1]
            assert abs(got - want) <= 0.01 * abs(a[i] - a[i - 1]) + 1e-12, (name, f, got, want)


@pytest.mark.parametrize(
    "engine, step, duration", [("mujoco", 1e-4, 0.20005), ("pybullet", 1e-3, 0.2004)]
)
def test_the_last_sample_is_at_a_duration_that_is_not_whole_steps(
    engine: str, step: float, duration: float
) -> None:
    """Through the harness: the last step is shorter (it used to overrun the duration by up to
    half a step, or stop short of it) and the state there lies between its neighbours."""
    scene = scene_path("two-block-free-rocking")
    r = rockbench.run(scene, engine=engine, overrides=[f"duration={duration}"])
    assert r.t[-1] == duration and r.t[-2] == pytest.approx(0.2, abs=1e-12)
    assert len(r.t) == 202
    ref = rockbench.run(
        scene, engine=engine, overrides=[f"duration={0.2 + 2 * step}", f"output_interval={step}"]
    )
    at_duration_is_between_its_neighbours(r, ref, duration)


@pytest.mark.parametrize("engine", ENGINES)
def test_a_whole_number_of_steps_keeps_the_samples_at_whole_steps(engine: str) -> None:
    step = {"mujoco": 1e-4, "pybullet": 1e-3}[engine]
    r = run_in_process(engine, scene_dict(duration=0.05, output_interval=7e-4))
    every = round(7e-4 / step)
    n = round(0.05 / step)
    assert np.array_equal(r.t, np.array(list(range(0, n, every)) + [n], dtype=float) * step)


# Siconos runs under its own interpreter (`make siconos`), as the Rust harness runs it.


def siconos_python() -> str:
    path = os.environ.get("ROCKBENCH_SICONOS_PYTHON") or str(ROOT / ".siconos-venv" / "bin" / "python")
    if not Path(path).exists():
        pytest.fail(f"no Siconos interpreter at {path}: run `make siconos`")
    return path


def siconos_input(d: dict[str, Any]) -> dict[str, Any]:
    """What the Rust harness writes for the worker (``siconos::input`` in
    src/engines/siconos.rs): the scene, the layout, supports, friction and ground velocities
    at the worker's step ends: whole steps, then the duration where the last step is shorter."""
    scene = rockbench.load_scene(d)
    spec = json.loads(scene.to_json())
    layout = scene.layout()
    names = [b["name"] for b in layout]
    supports = [None if b["support"] is None else names.index(b["support"]) for b in layout]
    out: dict[str, Any] = {
        "scene": spec,
        "layout": [{k: b[k] for k in ("x", "z", "phi", "vx", "vz", "omega")} for b in layout],
        "supports": supports,
        "friction_below": [scene.friction_between(supports[i], i) for i in range(len(layout))],
    }
    if "excitation" in spec:
        h = (spec.get("siconos") or {}).get("step", 1e-4)
        steps = spec["duration"] / h
        whole = max(1, math.floor(steps + 1e-9))
        ends = list(np.arange(whole + 1) * h) + ([spec["duration"]] if steps - whole > 1e-9 else [])
        gm = scene.ground_motion(ends)
        out["ground"] = {"step": h, "vx": gm["vx"].tolist(), "vz": gm["vz"].tolist()}
    return out


def run_siconos(d: dict[str, Any], tmp: Path) -> tuple[subprocess.CompletedProcess[str], Any, dict[str, Any]]:
    tmp.mkdir(parents=True, exist_ok=True)
    (tmp / "input.json").write_text(json.dumps(siconos_input(d)))
    worker = ROOT / "python" / "rockbench" / "siconos_worker.py"
    p = subprocess.run(
        [siconos_python(), str(worker), "--input", str(tmp / "input.json"), "--out", str(tmp / "out")],
        capture_output=True,
        text=True,
        env={**os.environ, "OPENBLAS_NUM_THREADS": "1"},
        timeout=300,
    )
    if p.returncode != 0:
        return p, None, {}
    data = np.loadtxt(tmp / "out" / "trajectory.csv", delimiter=",", skiprows=1, ndmin=2)
    summary = json.loads((tmp / "out" / "summary.json").read_text())
    return p, data, summary


class Trajectory:
    """A worker's trajectory.csv as ``t`` and ``blocks[name][field]``."""

    def __init__(self, data: Any, names: list[str]) -> None:
        self.t = data[:, 0]
        self.blocks = {
            n: {f: data[:, 1 + 6 * i + j] for j, f in enumerate(common.FIELDS)} for i, n in enumerate(names)
        }


def test_siconos_ends_its_last_step_at_the_duration(tmp_path: Path) -> None:
    d = scene_dict("two-block-free-rocking", duration=0.05006)
    p, data, summary = run_siconos(d, tmp_path / "partial")
    assert p.returncode == 0, p.stderr
    names = ["pedestal", "statue"]
    r = Trajectory(data, names)
    assert r.t[-1] == 0.05006 and r.t[-2] == 500 * 1e-4
    assert summary["steps"] == 501 and summary["notes"] == []
    d = scene_dict("two-block-free-rocking", duration=0.0502, output_interval=1e-4)
    p, data, _ = run_siconos(d, tmp_path / "ref")
    assert p.returncode == 0, p.stderr
    at_duration_is_between_its_neighbours(r, Trajectory(data, names), 0.05006)


def test_siconos_whole_steps_keep_their_samples_and_an_excited_last_step_takes_its_own_motion(
    tmp_path: Path,
) -> None:
    d = scene_dict(duration=0.05, output_interval=7e-4)
    p, data, _ = run_siconos(d, tmp_path / "whole")
    assert p.returncode == 0, p.stderr
    assert np.array_equal(data[:, 0], np.array(list(range(0, 500, 7)) + [500], dtype=float) * 1e-4)
    # The rocking block (tilted at the start) under a pulse (4 m/s^2 at 0.05 s): the shorter
    # last step, given the ground's velocity at the duration, ends between the states of a run
    # of whole steps around it.
    pulse = {"horizontal": {"kind": "half-sine", "amplitude": 8.0, "duration": 0.3}}
    names = ["block"]
    ref_d = scene_dict(duration=0.0502, output_interval=1e-4, excitation=pulse)
    p, data, _ = run_siconos(ref_d, tmp_path / "pulse-ref")
    assert p.returncode == 0, p.stderr
    ref = Trajectory(data, names)
    for duration in (0.05003, 0.05007):
        d = scene_dict(duration=duration, excitation=pulse)
        p, data, summary = run_siconos(d, tmp_path / f"pulse-{duration}")
        assert p.returncode == 0, p.stderr
        assert data[-1, 0] == duration and summary["notes"] == []
        assert abs(ref.blocks["block"]["omega"][-1]) > 0.1, "the block rocks there"
        at_duration_is_between_its_neighbours(Trajectory(data, names), ref, duration)


def test_siconos_refuses_a_last_step_its_events_cannot_tell_from_a_whole_one(tmp_path: Path) -> None:
    # 1e-6 s steps: the last one 5e-15 s short of a whole step (5e-9 of it, not whole by the
    # native rule) is within the resolution of Siconos' event times.
    d = scene_dict(duration=2e-3 - 5e-15, siconos={"step": 1e-6})
    p, _, _ = run_siconos(d, tmp_path)
    assert p.returncode == 2, p.stderr
    assert p.stderr.strip() == (
        "siconos.step: the last step, 1e-06 s to the duration (0.001999999999995 s), is too "
        "close to a whole step for Siconos' events to tell apart: make the duration a whole "
        "number of steps (got 1e-06)"
    )


@pytest.mark.parametrize(
    "engine, module",
    [
        ("mujoco", "rockbench.engines.mujoco_engine"),
        ("pybullet", "rockbench.engines.pybullet_engine"),
        ("siconos", "rockbench.siconos_worker"),
    ],
)
def test_check_refuses_a_worker_setting_its_worker_does_not_know(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, engine: str, module: str
) -> None:
    """`rockbench check` refuses an unknown setting of a worker engine's table, as the worker
    would at the run, and the names it knows are exactly the worker's own."""
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", os.environ.get("OPENBLAS_NUM_THREADS", "1"))
    settings = importlib.import_module(module).SETTINGS
    scene = tmp_path / "s.toml"
    text = Path(scene_path("housner-square")).read_text()
    scene.write_text(f"{text}\n[{engine}]\nbogus = 1\n")
    r = subprocess.run(
        [str(ROOT / "target/release/rockbench"), "check", str(scene)],
        capture_output=True, text=True, check=False,
    )
    assert r.returncode == 1 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    m = re.search(rf"{engine}\.bogus: unknown setting \(known: (.*)\)$", r.stderr.strip())
    assert m, r.stderr
    assert m.group(1).split(", ") == sorted(settings)
