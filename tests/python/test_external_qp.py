"""The step problems `examples/wall_problems.rs` writes, as `benches/walls/external_qp.py` reads
them: the QP it builds from a problem is the one the native back-end solved (scipy's SLSQP, an
independent solver, finds the native displacement on a small sliding wall's steps), and a file
that is not a step problem is one line naming it."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize

from conftest import ROOT, SLIDING_WALL_STEPS

sys.path.insert(0, str(ROOT / "benches" / "walls"))
import external_qp  # noqa: E402


def slsqp(st: external_qp.Step) -> np.ndarray:
    """`min 1/2 u'Pu + q'u s.t. D u + r >= 0` by SLSQP from the free minimiser."""
    d = st.d.toarray()
    res = minimize(
        lambda u: 0.5 * u @ (st.p * u) + st.q @ u,
        -st.q / st.p,
        jac=lambda u: st.p * u + st.q,
        constraints=[{"type": "ineq", "fun": lambda u: d @ u + st.r, "jac": lambda _u: d}],
        method="SLSQP",
        options={"ftol": 1e-16, "maxiter": 500},
    )
    assert res.success, res.message
    return res.x


def test_the_problems_are_those_native_solved(sliding_wall_problems: Path) -> None:
    files = sorted(sliding_wall_problems.glob("step-*.json"))
    assert len(files) == SLIDING_WALL_STEPS
    sliding = 0
    for f in files:
        st = external_qp.load_step(f)
        assert st.p.size == 15 and st.r.size > 0
        u = slsqp(st)
        # Metres of the step's displacement: SLSQP's answer is the native one.
        assert np.abs(u - st.native_u).max() * st.dt < 1e-10, f.name
        # The cold native solve finds the same displacement as the warm one.
        assert np.abs(st.cold_u - st.native_u).max() * st.dt < 1e-12, f.name
        _, complementarity, violation = external_qp.native_residuals(st)
        assert violation < 1e-12 and complementarity < 1e-12, f.name
        # Contact points loaded on one edge of the cone only: slipping at the cone's edge.
        z = st.native_z.reshape(-1, 2)
        big = z.max()
        sliding += int(np.sum((z.max(axis=1) > 1e-3 * big) & (z.min(axis=1) < 1e-9 * big)))
    assert sliding > 0, "no point slips: the problems do not test the cone's rows"


def test_the_external_solvers_table_lists_native(
    sliding_wall_problems: Path, tmp_path: Path
) -> None:
    """The table has a row for native and one for each solver asked for; without the optional
    solvers installed (`make bench-walls-external-qp` installs them) native's alone."""
    out = tmp_path / "table.md"
    assert external_qp.main([str(sliding_wall_problems), "--solvers", "", "--out", str(out)]) == 0
    text = out.read_text()
    assert "native (warm, as in the run)" in text
    assert f"| {sliding_wall_problems.name} | 15 |" in text
    # What produced the problems: the scene, rockbench's version and the native settings.
    assert "wall.toml`, rockbench " in text and "native dt 0.001" in text
    assert (tmp_path / "table.json").exists()
    assert not list(tmp_path.glob("*.partial"))


def test_a_file_that_is_no_step_problem_is_one_line(
    sliding_wall_problems: Path, tmp_path: Path
) -> None:
    bad = tmp_path / "steps"
    bad.mkdir()
    with pytest.raises(SystemExit) as e:
        external_qp.main([str(bad), "--out", str(tmp_path / "t.md")])
    assert str(e.value).startswith(f"error: {bad / 'provenance.json'}: provenance: ")
    (bad / "provenance.json").write_text((sliding_wall_problems / "provenance.json").read_text())
    (bad / "step-0001.json").write_text('{"problem": {"mass": [1, 1, 1]}}')
    with pytest.raises(SystemExit) as e:
        external_qp.main([str(bad), "--out", str(tmp_path / "t.md")])
    message = str(e.value)
    assert message.startswith(f"error: {bad / 'step-0001.json'}: problem: ")
    assert "\n" not in message
    assert not (tmp_path / "t.md").exists()


def test_an_unknown_solver_is_refused(sliding_wall_problems: Path, tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as e:
        external_qp.main(
            [str(sliding_wall_problems), "--solvers", "Gurobi", "--out", str(tmp_path / "t.md")]
        )
    assert "--solvers: unknown ['Gurobi']" in str(e.value)


def test_a_solver_without_an_answer_in_time_is_stopped(
    sliding_wall_problems: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A solver that does not return is stopped after the time limit and its margin; the rest
    of the set counts as not run, and the table still gets written."""

    def hangs(_st, _warm):
        time.sleep(60)

    monkeypatch.setattr(external_qp, "TIME_LIMIT", 0.2)
    monkeypatch.setattr(external_qp, "ANSWER_MARGIN", 0.8)
    monkeypatch.setattr(external_qp, "SOLVERS", [("Hangs", hangs, False)])
    t0 = time.perf_counter()
    rows = external_qp.run([sliding_wall_problems], None)
    assert time.perf_counter() - t0 < 30
    mine = [r for r in rows if r["solver"] == "Hangs"]
    assert [r["status"] for r in mine] == ["no answer within the time limit"] + [
        "not run (an earlier problem over the time limit)"
    ] * (SLIDING_WALL_STEPS - 1)
    assert "| Hangs | 0 of 5 | - | - | - | - |" in external_qp.table(rows)


def test_wall_problems_refuses_a_missing_scene_in_one_line(
    sliding_wall_problems: Path, tmp_path: Path
) -> None:
    exe = ROOT / "target" / "release" / "examples" / "wall_problems"
    missing = tmp_path / "no-such-scene.toml"
    out = subprocess.run(
        [str(exe), str(missing), "3", str(tmp_path / "steps")], capture_output=True, text=True
    )
    assert out.returncode != 0
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "no-such-scene.toml" in lines[0]
    assert not (tmp_path / "steps").exists()
    out = subprocess.run(
        [str(exe), str(missing), "0", str(tmp_path / "s")], capture_output=True, text=True
    )
    assert out.returncode != 0
    assert out.stderr.strip() == 'error: STEPS: "0" is not a whole number of steps, 1 or more'
