"""The Rust core from Python: scenes, runs, layout and ground motion."""

from __future__ import annotations

import csv
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import rockbench
from conftest import ROOT, scene_path
from rockbench.engines.common import mean_ground_acceleration

FIELDS = ("x", "z", "phi", "vx", "vz", "omega")


def test_public_names_come_from_the_native_module() -> None:
    assert set(rockbench.__all__) == {
        "Comparison",
        "FragilityResult",
        "Run",
        "Scene",
        "__git_commit__",
        "__source_hash__",
        "__version__",
        "compare",
        "engine_names",
        "fragility",
        "fragility_is_python_worker",
        "fragility_run",
        "fragility_run_specs",
        "fragility_study",
        "load_scene",
        "run",
        "run_many",
        "trajectory",
    }
    python_side = {"compare", "fragility", "run_many", "trajectory", "Comparison", "FragilityResult"}
    for name in set(rockbench.__all__) - python_side:
        assert getattr(rockbench, name) is getattr(rockbench._native, name)
    # `compare` wraps the native `compare_rows` in a pandas DataFrame.
    assert rockbench.compare.__module__ == "rockbench.compare"
    assert {"native", "housner", "mujoco", "pybullet"} <= set(rockbench.engine_names())


def test_run_native_returns_arrays_equal_to_the_cli_output(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(ROOT)
    r = rockbench.run("validation/scenes/housner-slender.toml", engine="native")
    assert isinstance(r.t, np.ndarray) and r.t.dtype == np.float64
    assert list(r.blocks) == ["block"]
    b = r.blocks["block"]
    assert set(b) == set(FIELDS)
    for f in FIELDS:
        assert isinstance(b[f], np.ndarray) and b[f].shape == r.t.shape
    assert r.t[0] == 0.0 and r.t[-1] == pytest.approx(4.0)
    assert b["phi"][0] == pytest.approx(0.15, abs=1e-12)
    s = r.summary
    assert s["engine"] == "native" and s["samples"] == len(r.t)
    assert s["settings"]["dt"] > 0
    assert len(s["blocks"][0]["impacts"]) >= 3
    # The summary names the program that made it.
    assert s["rockbench_git_commit"] == rockbench.__git_commit__
    assert s["rockbench_source_hash"] == rockbench.__source_hash__
    assert len(rockbench.__source_hash__) == 16
    # The same run through the command line writes the same numbers.
    out = tmp_path / "cli"
    subprocess.run(
        [str(ROOT / "target/release/rockbench"), "run", scene_path("housner-slender"),
         "--engine", "native", "--out", str(out)],
        check=True, capture_output=True,
    )
    with open(out / "trajectory.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(r.t)
    phi = np.array([float(x["block_phi"]) for x in rows])
    np.testing.assert_array_equal(phi, b["phi"])


def test_a_scene_dict_loads_like_its_file() -> None:
    s1 = rockbench.load_scene(scene_path("two-block-free-rocking"))
    s2 = rockbench.load_scene(s1.to_dict())
    assert s2.to_dict() == s1.to_dict()
    assert s2.layout() == s1.layout()
    assert s2.source == "<dict>"
    assert s1.block_names == ["pedestal", "statue"]
    # A loaded Scene, its dict and its file run identically.
    h = rockbench.load_scene(scene_path("housner-square"))
    runs = [rockbench.run(x, engine="housner") for x in (h, h.to_dict(), scene_path("housner-square"))]
    for r in runs[1:]:
        np.testing.assert_array_equal(r.blocks["block"]["phi"], runs[0].blocks["block"]["phi"])


def test_overrides_apply_to_files() -> None:
    s = rockbench.load_scene(scene_path("housner-slender"), ["duration=0.5", "mujoco.timestep=2e-4"])
    assert s.duration == 0.5
    assert s.to_dict()["mujoco"] == {"timestep": 2e-4}


def test_a_bad_scene_raises_value_error_with_one_line_naming_the_field(tmp_path: Path) -> None:
    d = rockbench.load_scene(scene_path("housner-square")).to_dict()
    d["duration"] = -1.0
    with pytest.raises(ValueError) as e:
        rockbench.load_scene(d)
    assert str(e.value) == "<dict>: duration: must be a positive number (got -1)"
    d["duration"] = 1.0
    d["blocks"][0]["width"] = float("nan")
    with pytest.raises(ValueError) as e:
        rockbench.load_scene(d)
    assert str(e.value) == "<dict>: blocks[0].width: must be a finite number (got NaN)"
    p = tmp_path / "bad.toml"
    p.write_text('name = "b"\nduration = 1\n[[blocks]]\nname = "a"\nwidth = "wide"\nheight = 1\n')
    with pytest.raises(ValueError) as e:
        rockbench.load_scene(p)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(f"{p}: blocks[0].width:"), msg
    with pytest.raises(ValueError, match="cannot read"):
        rockbench.run(tmp_path / "missing.toml")
    with pytest.raises(ValueError, match="unknown engine `nope`"):
        rockbench.run(scene_path("housner-square"), engine="nope")


def test_layout_puts_the_stack_on_its_pivot_corners() -> None:
    """The tilted two-block stack: the pedestal's left corner on the ground, the statue's left
    corner on the pedestal's top face, both rotated by the tilt (geometry checked here)."""
    s = rockbench.load_scene(scene_path("two-block-free-rocking"))
    lay = {b["name"]: b for b in s.layout()}

    def corner(b: dict, w: float, h: float, sx: float, sz: float) -> np.ndarray:
        c, si = np.cos(b["phi"]), np.sin(b["phi"])
        lx, lz = sx * w / 2, sz * h / 2
        return np.array([b["x"] + c * lx - si * lz, b["z"] + si * lx + c * lz])

    ped, sta = lay["pedestal"], lay["statue"]
    assert ped["support"] is None and sta["support"] == "pedestal"
    assert ped["phi"] == pytest.approx(0.15) and sta["phi"] == pytest.approx(0.15)
    assert corner(ped, 1.25, 1.25, -1, -1) == pytest.approx([-0.625, 0.0], abs=1e-12)
    # Statue (1.0 wide) centred on the pedestal: its bottom-left corner lies on the pedestal's
    # top face, 0.125 m in from the pedestal's top-left corner.
    top_left = corner(ped, 1.25, 1.25, -1, 1)
    along = np.array([np.cos(0.15), np.sin(0.15)])
    assert corner(sta, 1.0, 2.5, -1, -1) == pytest.approx(top_left + 0.125 * along, abs=1e-12)
    assert all(lay[n][k] == 0.0 for n in lay for k in ("vx", "vz", "omega"))


def _pulse_scene(kind: str) -> rockbench.Scene:
    d = rockbench.load_scene(scene_path("housner-slender")).to_dict()
    d["excitation"] = {"horizontal": {"kind": kind, "amplitude": 2.0, "duration": 0.4, "start": 0.1}}
    return rockbench.load_scene(d)


@pytest.mark.parametrize("kind", ["half-sine", "one-sine", "rectangular"])
def test_ground_motion_is_the_closed_form_pulse(kind: str) -> None:
    t = np.linspace(0.0, 1.0, 1001)
    gm = _pulse_scene(kind).ground_motion(t)
    s = t - 0.1
    inside = (s >= 0) & (s <= 0.4)
    shape = {
        "half-sine": np.sin(np.pi * s / 0.4),
        "one-sine": np.sin(2 * np.pi * s / 0.4),
        "rectangular": np.ones_like(s),
    }[kind]
    np.testing.assert_allclose(gm["ax"], np.where(inside, 2.0 * shape, 0.0), atol=1e-12)
    # Velocity is the integral of the acceleration (trapezoid on a fine grid).
    tf = np.linspace(0.0, 1.0, 200_001)
    af = rockbench.load_scene(_pulse_scene(kind).to_dict()).ground_motion(tf)["ax"]
    v = np.concatenate([[0.0], np.cumsum(0.5 * (af[1:] + af[:-1]) * np.diff(tf))])
    np.testing.assert_allclose(gm["vx"], v[::200], atol=2e-4)
    assert not gm["az"].any() and not gm["dz"].any()


def test_mean_ground_acceleration_gives_the_exact_velocity_change() -> None:
    sc = _pulse_scene("half-sine")
    bounds = np.arange(0, 1001) * 1e-3
    ax, az = mean_ground_acceleration(sc, bounds)
    v = sc.ground_motion(bounds)["vx"]
    np.testing.assert_allclose(np.cumsum(ax * 1e-3), v[1:], atol=1e-12)
    assert v[-1] == pytest.approx(2.0 * 0.4 * 2 / np.pi)  # A T 2/pi for a half-sine


def test_runs_release_the_gil() -> None:
    """While a native run is in progress on another thread, this thread keeps running."""
    done = threading.Event()
    err: list[BaseException] = []

    def work() -> None:
        try:
            # Clarabel keeps the run long enough to observe (the default back-end takes ~10 ms).
            rockbench.run(
                scene_path("two-block-free-rocking"),
                engine="native",
                overrides=["duration=6.0", 'native.solver="clarabel"'],
            )
        except BaseException as e:  # pragma: no cover - reported below
            err.append(e)
        done.set()

    th = threading.Thread(target=work)
    th.start()
    time.sleep(0.05)
    n = 0
    start = time.perf_counter()
    while not done.is_set():
        n += 1
    took = time.perf_counter() - start
    th.join()
    assert not err, err
    assert took > 0.1, f"the run finished too fast to tell ({took:.3f} s)"
    assert n > 10_000, f"only {n} iterations in {took:.3f} s: the GIL was held"


def test_stubs_match_the_extension() -> None:
    r = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "rockbench._native"],
        capture_output=True, text=True, cwd=ROOT,
    )
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_package_type_checks() -> None:
    r = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "python/rockbench"],
        capture_output=True, text=True, cwd=ROOT,
    )
    assert r.returncode == 0, r.stdout + r.stderr


def _long_study(tmp_path: Path) -> Path:
    """A fragility study of 2000 short runs (one block, one 2 s record, 2000 levels, 20 s
    tail, no early stop): some 40 s of work or more, each run a few hundredths of a second."""
    (tmp_path / "block.toml").write_text(
        'name = "block"\nduration = 1.0\n[[blocks]]\nname = "block"\nwidth = 0.3\n'
        "height = 1.5\n[contact]\nfriction = 2.0\n"
    )
    n, dt = 200, 0.01
    values = [f"{0.05 * np.sin(2 * np.pi * k * dt):15.7E}" for k in range(n)]
    rows = ["".join(values[k:k + 5]) for k in range(0, n, 5)]
    (tmp_path / "r0.AT2").write_text(
        "synthetic\nsine\nACCELERATION TIME SERIES IN UNITS OF G\n"
        f"NPTS= {n}, DT= {dt:.4f} SEC\n" + "\n".join(rows) + "\n"
    )
    (tmp_path / "suite.toml").write_text(
        '[suite]\nname = "one"\n\n[[record]]\nid = "r0"\nfile = "r0.AT2"\npair = "p0"\n'
        'event = "burst"\n'
    )
    levels = ", ".join(f"{0.001 * (k + 1):.3f}" for k in range(2000))
    study = tmp_path / "study.toml"
    study.write_text(
        'name = "long"\nscenes = ["block.toml"]\nsuite = "suite.toml"\nengines = ["native"]\n'
        f'cache = "cache"\ntail = 20.0\nearly_stop = false\n[intensity]\nmeasure = "pga"\n'
        f"levels = [{levels}]\n[fit]\nbootstrap = 0\n"
    )
    return study


def _worker_of(pid: int) -> int | None:
    """The pid of an external engine's worker started by process `pid`, if one is running."""
    for status in Path("/proc").glob("[0-9]*/status"):
        try:
            fields = dict(line.split(":\t", 1) for line in status.read_text().splitlines()
                          if ":\t" in line)
            cmdline = (status.parent / "cmdline").read_bytes()
        except OSError:
            continue
        if fields.get("PPid", "").strip() == str(pid) and b"rockbench.worker" in cmdline:
            return int(status.parent.name)
    return None


def _alive(pid: int) -> bool:
    """Whether `pid` is a process that has not ended (a zombie has)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.parametrize(
    "call", ["run-native", "run-rapier", "run-mujoco", "compare", "fragility"]
)
def test_ctrl_c_stops_the_work_and_raises_keyboard_interrupt(tmp_path: Path, call: str) -> None:
    """A SIGINT while the extension works (GIL released) stops it and raises KeyboardInterrupt,
    not a panic of NumPy's API: a run or a comparison of runs that would take some 1000 s (four
    hours of rocking at 1e-4 s a step), or a study of 2000 runs, which stops the runs under way
    and keeps those done. The process must be done within 60 s of the signal. An
    external engine's worker, which the signal sent to the Python process alone does not reach,
    is killed, not left running."""
    scene = tmp_path / "long.toml"
    scene.write_text(
        'name = "long"\nduration = 14400.0\n[output]\ninterval = 1.0\n[[blocks]]\nname = "b"\n'
        'width = 0.4\nheight = 1.0\n[initial]\ntilt = 0.05\n[native]\ndt = 1e-4\n'
        "[rapier]\ndt = 1e-4\n"
    )
    work = {
        "run-native": f"rockbench.run({str(scene)!r}, engine='native')",
        "run-rapier": f"rockbench.run({str(scene)!r}, engine='rapier')",
        "run-mujoco": f"rockbench.run({str(scene)!r}, engine='mujoco')",
        "compare": f"rockbench.compare({str(scene)!r}, engines=['native', 'rapier'])",
        "fragility": f"rockbench.fragility({str(_long_study(tmp_path))!r})",
    }[call]
    code = (
        "import sys, rockbench\n"
        "print('started', flush=True)\n"
        "try:\n"
        f"    {work}\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted', flush=True)\n"
        "    sys.exit(3)\n"
    )
    p = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert p.stdout is not None
    assert p.stdout.readline().strip() == "started"
    time.sleep(0.5)
    if call == "fragility":  # signalled once the study is running its runs
        deadline = time.monotonic() + 60
        while not list((tmp_path / "cache").rglob("*.json")) and time.monotonic() < deadline:
            time.sleep(0.05)
    worker = None
    if call == "run-mujoco":  # signalled once the worker runs
        deadline = time.monotonic() + 60
        while (worker := _worker_of(p.pid)) is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert worker is not None, "no worker started"
    p.send_signal(2)
    try:
        out, err = p.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        p.kill()
        p.communicate()
        raise AssertionError("the run went on after Ctrl-C") from None
    assert p.returncode == 3, f"{out}\n{err}"
    assert "interrupted" in out and "PanicException" not in err, err
    if worker is not None:
        deadline = time.monotonic() + 10
        while _alive(worker) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _alive(worker), "the worker was left running"
    if call == "fragility":
        stored = list((tmp_path / "cache").rglob("*.json"))
        assert 0 < len(stored) < 2000, f"{len(stored)} runs stored"
        assert not list((tmp_path / "cache").rglob("*.tmp-*")), "a half-written entry"


def test_importing_the_extension_loads_numpy() -> None:
    """NumPy's API is loaded when the extension is, not by the first array a run returns, where
    a Ctrl-C arriving during NumPy's import would be a panic rather than a KeyboardInterrupt."""
    r = subprocess.run(
        [sys.executable, "-c", "import sys, rockbench._native; print('numpy' in sys.modules)"],
        capture_output=True, text=True, cwd=ROOT,
    )
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "True"


def test_ground_motion_takes_numbers_and_sequences_and_refuses_times_that_are_not_finite() -> None:
    sc = rockbench.load_scene(ROOT / "validation/scenes/earthquake-elcentro.toml")
    ts = np.array([0.0, 1.234, 2.5])
    ax = sc.ground_motion(ts)["ax"]
    assert np.array_equal(sc.ground_motion(list(ts))["ax"], ax)
    assert np.array_equal(sc.ground_motion(ts.astype(np.float32).astype(np.float64))["ax"],
                          sc.ground_motion(ts.astype(np.float32))["ax"])
    assert sc.ground_motion(np.float64(1.234))["ax"][0] == ax[1]
    assert sc.ground_motion(ts[::2])["ax"].tolist() == [ax[0], ax[2]]  # a strided view
    for bad in (np.nan, -np.inf):
        with pytest.raises(ValueError, match=r"ground_motion: t\[1\] = .* is not a finite time"):
            sc.ground_motion([0.5, bad])
    with pytest.raises(ValueError, match="1-D sequence of times .got 2 dimensions"):
        sc.ground_motion(np.zeros((2, 2)))
    # A complex time's imaginary part is not dropped, nor booleans read as 0 and 1 s.
    for bad, kind in (([0.5, 1.0 + 2.0j], "c"), ([True, False], "b"), (["1.5"], "U")):
        with pytest.raises(ValueError, match=f"real numbers of seconds .*kind '{kind}'"):
            sc.ground_motion(bad)


def _block_dict(**extra: Any) -> dict[str, Any]:
    d: dict[str, Any] = {
        "name": "d", "duration": 0.2, "blocks": [{"name": "b", "width": 0.4, "height": 1.0}],
    }
    d.update(extra)
    return d


def test_a_scene_dict_that_refers_to_itself_or_nests_too_deep_is_a_value_error() -> None:
    """Each raised ValueError; the interpreter crashed (a stack overflow) before."""
    code = (
        "import rockbench\n"
        "d = {'name': 'x', 'duration': 0.2, 'blocks': [{'name': 'b', 'width': 1.0, 'height': 2.5}]}\n"
        "d['native'] = d\n"
        "for scene in (d, dict(d, native={'dt': __import__('functools').reduce(lambda a, _: [a], range(100000), 1.0)})):\n"
        "    try:\n"
        "        rockbench.load_scene(scene)\n"
        "    except ValueError as e:\n"
        "        print('refused:', str(e)[:60])\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
    lines = r.stdout.splitlines()
    assert len(lines) == 2 and all(l.startswith("refused: <dict>: (file): not JSON data") for l in lines), r.stdout


def test_numpy_values_in_a_scene_dict_are_their_python_values() -> None:
    plain = rockbench.load_scene(_block_dict(duration=1.0, native={"dt": 1e-3}))
    numpy = rockbench.load_scene(
        _block_dict(duration=np.int64(1), native={"dt": np.float32(1e-3), "sleep": np.bool_(False)})
    )
    assert numpy.duration == plain.duration == 1.0
    assert numpy.to_dict()["native"]["dt"] == float(np.float32(1e-3))
    with pytest.raises(ValueError, match=r"<dict>: native.dt: must be a finite number \(got NaN\)"):
        rockbench.load_scene(_block_dict(native={"dt": np.float32("nan")}))


def test_a_block_cannot_touch_itself() -> None:
    sc = rockbench.load_scene(_block_dict(blocks=[
        {"name": "p", "width": 0.4, "height": 1.0}, {"name": "s", "width": 0.4, "height": 1.0},
    ]))
    assert sc.friction_between(0, 1) == sc.friction_between(None, 0)
    with pytest.raises(ValueError, match="block 1 cannot touch itself"):
        sc.friction_between(1, 1)


def test_run_many_refuses_no_engine_and_unknown_engines_before_any_run() -> None:
    with pytest.raises(ValueError, match="run_many: engines: name at least one engine"):
        rockbench.run_many([_block_dict()], engines=[])
    with pytest.raises(ValueError, match="run_many: engines: unknown engine `nope`"):
        rockbench.run_many([_block_dict()], engines=["native", "nope"])
    # A scene that is none (it was an AttributeError from inside the runs).
    for bad in (None, 5, b"x"):
        with pytest.raises(TypeError, match=r"run_many: scenes\[1\] is a \w+; a scene is a path, a dict or a Scene"):
            rockbench.run_many([_block_dict(), bad])


def test_run_many_refuses_a_binary_file_before_any_run(tmp_path: Path) -> None:
    """A `.toml` that is not text is bad input: a ValueError naming the file (it was a failed
    row), not a study and not a UnicodeDecodeError."""
    path = tmp_path / "binary.toml"
    path.write_bytes(b"\x9f\x00\xff garbage")
    for given in (str(path), [str(path)]):
        with pytest.raises(ValueError, match=f"^{path}: .*cannot read"):
            rockbench.run_many(given)
