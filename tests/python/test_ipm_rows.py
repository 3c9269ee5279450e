"""The forms `benches/walls/ipm_rows.py` solves a step problem in: the reduced ones keep the whole
problem's minimiser, the lifted one is the vertex law where a pair's tangential rows agree
(each checked by scipy's SLSQP, an independent solver, on a small sliding wall's steps), and a
directory without problems is one line naming it."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize

from conftest import ROOT, SLIDING_WALL_STEPS

sys.path.insert(0, str(ROOT / "benches" / "walls"))
import external_qp  # noqa: E402
import ipm_rows  # noqa: E402


def slsqp(problem: ipm_rows.Problem, _tolerance: float) -> ipm_rows.Solved:
    """`min 1/2 x'Px + q'x s.t. D x + r >= 0` by SLSQP, with its multipliers."""
    p, q, d, r = problem
    dense = d.toarray()
    start = np.where(p > 0, -q / np.where(p > 0, p, 1.0), 0.0)
    res = minimize(
        lambda x: 0.5 * x @ (p * x) + q @ x,
        start,
        jac=lambda x: p * x + q,
        constraints=[{"type": "ineq", "fun": lambda x: dense @ x + r, "jac": lambda _x: dense}],
        method="SLSQP",
        options={"ftol": 1e-16, "maxiter": 1000},
    )
    assert res.success, res.message
    return ipm_rows.Solved(res.x, np.asarray(res.multipliers), int(res.nit), "Solved")


def steps(directory: Path) -> list[external_qp.Step]:
    files = sorted(directory.glob("step-*.json"))
    assert len(files) == SLIDING_WALL_STEPS
    return [external_qp.load_step(f) for f in files]


def test_every_form_has_the_whole_problems_answer(sliding_wall_problems: Path) -> None:
    rows = [ipm_rows.study(st, slsqp) for st in steps(sliding_wall_problems)]
    for row in rows:
        assert row.closed + row.open == row.rows
        for form in ipm_rows.FORMS:
            for tol, result in row.forms[form].items():
                # Metres of the step's displacement, against the whole problem's minimiser.
                assert result["distance_m"] < 1e-10, (row.step, form, tol, result)
                assert result["violation_m"] < 1e-10, (row.step, form, tol, result)
    # The reduced forms leave rows out: closed and open rows both occur, and loaded ones.
    assert sum(r.closed for r in rows) > 0 and sum(r.open for r in rows) > 0
    assert any(r.closed - r.unloaded > 0 for r in rows)
    table = ipm_rows.table(rows)
    assert table.count("\n| ") == 1 + len(rows)
    for form in ipm_rows.FORMS:
        assert f" {form} |" in table


def test_the_points_of_one_interface_share_a_group(sliding_wall_problems: Path) -> None:
    for st in steps(sliding_wall_problems):
        groups = ipm_rows.interfaces(st)
        assert sorted(k for g in groups for k in g) == list(range(st.mu.size))
        blocks = [
            {int(j) // 3 for j in st.d.indices[st.d.indptr[2 * k] : st.d.indptr[2 * k + 1]]}
            for k in range(st.mu.size)
        ]
        offsets = ipm_rows.tangential_offsets(st)
        for g in groups:
            assert all(blocks[k] == blocks[g[0]] for k in g)
            assert np.ptp(offsets[g]) < ipm_rows.SAME_OFFSET
        # A block on the ground, and blocks on each other, bear on two points a face.
        assert any(len(g) == 2 for g in groups)
        p, q, d, r = ipm_rows.lifted(st, groups)
        assert d.shape == (sum(2 + len(g) for g in groups), st.p.size + len(groups))
        assert np.all(p[st.p.size :] == 0) and np.all(q[st.p.size :] == 0)


def test_a_directory_without_problems_is_one_line(
    sliding_wall_problems: Path, tmp_path: Path
) -> None:
    empty = tmp_path / "steps"
    empty.mkdir()
    (empty / "provenance.json").write_text((sliding_wall_problems / "provenance.json").read_text())
    with pytest.raises(SystemExit) as e:
        ipm_rows.main([str(empty), "--out", str(tmp_path / "t.md")])
    message = str(e.value)
    assert message == f"error: {empty}: step-*.json: no step problems (written by wall_problems)"
    assert not list(tmp_path.glob("t.*"))
