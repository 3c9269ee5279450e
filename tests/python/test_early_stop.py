"""The worker's early-stop rule (``rockbench.engines.common.EarlyStop``, the rule of
``src/fragility/early.rs``): the static threshold of a stack where it rests, the quiet time of
the record, the window of stillness, and a bad rule file as one line with exit code 2.
(tests/fragility_engines.rs runs the rule in MuJoCo and PyBullet against full-length runs.)"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

from rockbench.engines.common import EarlyStop

ROOT = Path(__file__).resolve().parents[2]


def rule(load: list[list[float]], record_end: float) -> dict[str, Any]:
    """The rule of the paper's statue on its pedestal (as EarlyStopSpec::soft writes it)."""
    return {
        "rest_speed": 1e-3,
        "upright": 1e-4,
        "rest_window": 0.05,
        "on_side": math.pi / 2 - 1e-3,
        "record_end": record_end,
        "gravity": 9.81,
        "supports": [None, 0],
        "size": [1.25, 2.5],
        "upright_x": [0.0, 0.0],
        "stack": {
            "width": [1.25, 1.0],
            "height": [1.25, 2.5],
            "mass": [2500 * 1.25 * 1.25, 2500 * 2.5],
            "friction": [0.7, 0.7],
        },
        "load": load,
    }


def test_the_threshold_is_the_stacks_where_it_rests() -> None:
    es = EarlyStop(rule([], 0.0))
    mp, ms = 1.25 * 1.25, 2.5
    zc = (mp * 0.625 + ms * 2.5) / (mp + ms)
    assert abs(es.threshold([0.0, 0.0]) - 0.625 / zc) < 1e-12
    # The statue 0.3 m right of centre: its contact region is [-0.2, 0.625].
    x_c = ms * 0.3 / (mp + ms)
    want = min(0.325 / 1.25, (0.625 - x_c) / zc, 0.7)
    assert abs(es.threshold([0.0, 0.3]) - want) < 1e-12
    # Off the pedestal: no threshold at all.
    assert es.threshold([0.0, 1.2]) == 0.0


def test_the_quiet_time_is_the_end_of_the_last_segment_reaching_the_threshold() -> None:
    # Samples |a| 0.1 (t 0.06 -> 0.07), 2.0 (0.04 -> 0.05), 3.0 (0.02 -> 0.03), latest first.
    es = EarlyStop(rule([[0.1, 0.07], [2.0, 0.05], [3.0, 0.03]], 0.07))
    assert es.quiet_after(3.5) == 0.0
    assert es.quiet_after(2.5) == 0.03
    assert es.quiet_after(1.0) == 0.05
    assert es.quiet_after(0.05) == 0.07
    # The stack's threshold is 0.351 g = 3.45 m/s^2: quiet from the start.
    assert es.quiet_from == 0.0


def states(omega: float = 0.0, phi: float = 0.0) -> Any:
    s = np.zeros((2, 6))
    s[:, 1] = (0.625, 2.5)
    s[1, 2] = phi
    s[1, 5] = omega
    return s


def test_moving_or_tilted_blocks_restart_the_window() -> None:
    es = EarlyStop(rule([], 0.0))
    stop = None
    for k in range(1, 101):
        s = states(omega=2e-3 / 2.5 if k == 30 else 0.0)
        if (r := es.check(k * 1e-3, s)) is not None:
            stop = (r, k)
            break
    assert stop == ("at-rest", 80)
    es = EarlyStop(rule([], 0.0))
    assert all(es.check(k * 1e-3, states(phi=2e-4)) is None for k in range(1, 201))
    fallen = states(phi=math.pi / 2 - 5e-4)
    assert EarlyStop(rule([], 0.0)).check(0.5, fallen) == "overturned"


def test_a_record_above_the_threshold_keeps_a_still_stack_running() -> None:
    # 4 m/s^2 until 1.0 s exceeds the threshold (3.45 m/s^2): no rest stop before 1.0 s.
    es = EarlyStop(rule([[4.0, 1.0]], 2.0))
    hits = [(k, es.check(k * 1e-3, states())) for k in range(1, 1201)]
    first = next(k for k, h in hits if h is not None)
    assert first == 1001


def test_a_bad_rule_file_is_one_line_and_exit_2(tmp_path: Path) -> None:
    bad = tmp_path / "rule.json"
    bad.write_text(json.dumps({"rest_speed": 1e-3}))
    scene = ROOT / "validation" / "scenes" / "two-block-free-rocking.toml"
    p = subprocess.run(
        [sys.executable, "-m", "rockbench.worker", "--early-stop", str(bad), "--engine",
         "mujoco", "--scene", str(scene), "--out", str(tmp_path / "out")],
        capture_output=True, text=True, check=False,
    )
    assert p.returncode == 2, p.stderr
    lines = [x for x in p.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and "early-stop rule needs" in lines[0], p.stderr
    assert not (tmp_path / "out").exists()
