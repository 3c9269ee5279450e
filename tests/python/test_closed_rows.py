"""`benches/walls/closed_rows.py`: the closed rows of a step's solution agree with the forces the
native back-end reports (a loaded row is closed; a slipping point's other edge is open), the
changes between two closed sets are counted by row and by point, and a directory it cannot
compare is one line naming it."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from conftest import ROOT, SLIDING_WALL_STEPS

sys.path.insert(0, str(ROOT / "benches" / "walls"))
import closed_rows  # noqa: E402
import external_qp  # noqa: E402


def key(point: int, edge: int) -> int:
    return (point << 1) | edge


def test_changes_are_counted_by_row_and_by_point() -> None:
    before = {key(1, 0), key(1, 1), key(2, 0), key(5, 0)}
    now = {key(1, 0), key(3, 1), key(5, 1)}
    assert closed_rows.compare(before, now) == {
        # (3, 1) and (5, 1) entered; (1, 1), (2, 0) and (5, 0) left.
        "entered": 2,
        "left": 3,
        "changed": 5,
        # (5, 1) entered where (5, 0) was closed: point 5 reversed its slip.
        "reversals": 1,
        # Point 3 closed, point 2 opened; points 1 and 5 stayed closed on some edge.
        "points_closing": 1,
        "points_opening": 1,
    }
    assert closed_rows.compare(now, now)["changed"] == 0


def test_closed_rows_agree_with_the_native_forces(sliding_wall_problems: Path) -> None:
    """Every row that carries a force is closed (complementarity), and a point with one edge
    closed slips: its other edge's gap is `2 mu |slip|`, the slip `g_t + trow . dq` computed
    from the file's contact rows directly."""
    slipping = 0
    for f in sorted(sliding_wall_problems.glob("step-*.json")):
        st = external_qp.load_step(f)
        contacts = json.loads(f.read_text())["problem"]["contacts"]
        closed = closed_rows.closed_keys(st.d, st.native_u, st.r, st.keys, st.dt)
        z = st.native_z
        assert {int(k) for k in st.keys[z > 1e-9 * z.max()]} <= closed, f.name
        dq = st.native_u * st.dt
        gap = (st.d @ st.native_u + st.r) * st.dt
        for p, c in enumerate(contacts):
            edges = [int(st.keys[2 * p + e]) in closed for e in (0, 1)]
            if edges[0] != edges[1]:
                slip = c["g_t"] + sum(v * dq[int(j)] for j, v in c["trow"])
                open_gap = gap[2 * p + (1 if edges[0] else 0)]
                assert open_gap == pytest.approx(2 * c["mu"] * abs(slip), rel=1e-6), f.name
                slipping += 1
    assert slipping > 0, "no point slips: the problems do not test the cone's rows"


def test_the_table_has_a_row_a_step_after_the_first(
    sliding_wall_problems: Path, tmp_path: Path
) -> None:
    out = tmp_path / "closed.md"
    assert closed_rows.main([str(sliding_wall_problems), "--out", str(out)]) == 0
    rows = json.loads(out.with_suffix(".json").read_text())["rows"]
    assert [r["step"] for r in rows] == [
        f"step-{k:04d}" for k in range(2, SLIDING_WALL_STEPS + 1)
    ]
    for r in rows:
        assert r["changed"] == r["entered"] + r["left"] and r["closed"] <= r["rows"]
        assert r["changed_at"]["1e-10"] == r["changed"]
    assert f"| {sliding_wall_problems.name} | {SLIDING_WALL_STEPS - 1} | " in out.read_text()
    assert not list(tmp_path.glob("*.partial"))


def test_a_directory_of_one_step_is_refused_in_one_line(
    sliding_wall_problems: Path, tmp_path: Path
) -> None:
    one = tmp_path / "one"
    one.mkdir()
    for name in ("provenance.json", "step-0001.json"):
        (one / name).write_text((sliding_wall_problems / name).read_text())
    with pytest.raises(SystemExit) as e:
        closed_rows.main([str(one), "--out", str(tmp_path / "t.md")])
    message = str(e.value)
    assert message == (
        f"error: {one}: step-*.json: 1 step problems; two or more are compared"
    )
    assert not list(tmp_path.glob("t.*"))
