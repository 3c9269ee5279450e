"""How many closed rows change from one step's problem to the next.

`python benches/walls/closed_rows.py DIR [DIR ...] --out FILE.md` reads the step problems
`examples/wall_problems.rs` writes (`DIR/step-KKKK.json`, each step's first displacement problem
and the native solution of it; read by `external_qp.load_step`) and counts, between consecutive
steps, the rows of the solution that close and open. A row `i` (one edge of a contact point's
friction cone, keyed `(contact key << 1) | edge`) is closed when the step's displacement leaves
it at its bound:

    (D_i u + r_i) dt <= CLOSED (1 + |r_i dt|)        (metres of the step's displacement)

An exact method that finds the closed set by changing it (an active-set method, or a factor
followed by rank-one updates) changes it at least once for each row that entered or left it,
so these counts bound what such a method costs on a step (docs/walls.md, "How many
rows a moving wall's step changes, and what an exact solve of it costs"). Beside them: how many
contact points closed or opened, how many of the entering rows are the other edge of a point
that was closed (a slip that reverses), and the factorisations the native back-end spent on the
problem, warm as in the run and cold. `make bench-walls-closed-rows` runs it on the sliding
walls' ten pulse steps.
"""

from __future__ import annotations

import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from external_qp import fail, load_step, origins_list, provenance  # noqa: E402
from external_qp import problems_parser, write_table  # noqa: E402

#: A row is closed when the step leaves it within this of its bound, m, relative to
#: `1 + |r dt|`; the native back-end settles its rows to 1e-11 m.
CLOSED = 1e-10
#: The thresholds the changed rows are also counted at: how much the count depends on where a
#: row settled within the solver's tolerance counts as closed.
THRESHOLDS = (1e-13, 1e-12, 1e-11, 1e-10, 1e-9)


@dataclass
class Change:
    """The closed rows of one step's problem against those of the step before."""

    problems: str
    step: str
    rows: int
    closed: int
    #: Rows that entered and left the closed set, and their sum.
    entered: int
    left: int
    changed: int
    #: Entering rows whose point's other edge was closed: slips that reverse.
    reversals: int
    #: Contact points with no closed row before and one now, and the other way.
    points_closing: int
    points_opening: int
    factorisations: int
    cold_factorisations: int
    #: The changed rows with each of `THRESHOLDS` in place of `CLOSED` (keyed by `f"{t:g}"`).
    changed_at: dict[str, int]


def closed_keys(
    d: Any, u: np.ndarray, r: np.ndarray, keys: np.ndarray, dt: float, threshold: float = CLOSED
) -> set[int]:
    """The keys of the rows the displacement `u dt` leaves within `threshold` of their bound."""
    gap = (d @ u + r) * dt
    return {int(k) for k in keys[gap <= threshold * (1.0 + np.abs(r * dt))]}


def compare(before: set[int], now: set[int]) -> dict[str, int]:
    """The changes from one closed set to the next, counted by row and by contact point."""
    entered, left = now - before, before - now
    points_before = {k >> 1 for k in before}
    points_now = {k >> 1 for k in now}
    return {
        "entered": len(entered),
        "left": len(left),
        "changed": len(entered) + len(left),
        "reversals": sum(1 for k in entered if (k ^ 1) in before),
        "points_closing": len(points_now - points_before),
        "points_opening": len(points_before - points_now),
    }


def changes(directory: Path) -> list[Change]:
    """One row for each step after the first of a directory's problems."""
    files = sorted(directory.glob("step-*.json"))
    if len(files) < 2:
        fail(directory, "step-*.json", f"{len(files)} step problems; two or more are compared")
    out = []
    before: dict[float, set[int]] | None = None
    for f in files:
        st = load_step(f)
        now = {
            t: closed_keys(st.d, st.native_u, st.r, st.keys, st.dt, t)
            for t in {CLOSED, *THRESHOLDS}
        }
        if before is not None:
            out.append(
                Change(
                    problems=directory.name,
                    step=f.stem,
                    rows=int(st.r.size),
                    closed=len(now[CLOSED]),
                    **compare(before[CLOSED], now[CLOSED]),
                    factorisations=st.native_factorisations,
                    cold_factorisations=st.cold_factorisations,
                    changed_at={
                        f"{t:g}": compare(before[t], now[t])["changed"] for t in THRESHOLDS
                    },
                )
            )
        before = now
    return out


def table(rows: list[Change]) -> str:
    out = [
        "| problems | step | rows | closed | entered | left | changed | reversals "
        "| points closing | points opening | factorisations (cold) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in rows:
        out.append(
            f"| {c.problems} | {c.step} | {c.rows} | {c.closed} | {c.entered} | {c.left} "
            f"| {c.changed} | {c.reversals} | {c.points_closing} | {c.points_opening} "
            f"| {c.factorisations} ({c.cold_factorisations}) |"
        )
    names = [f"{t:g}" for t in THRESHOLDS]
    out += [
        "",
        "Changed rows a step, least / median / most, a row closed within each threshold, m:",
        "",
        "| problems | steps compared | " + " | ".join(names) + " |",
        "|---|---|" + "---|" * len(names),
    ]
    groups: dict[str, list[Change]] = {}
    for c in rows:
        groups.setdefault(c.problems, []).append(c)
    for problems, cs in groups.items():
        cells = []
        for name in names:
            changed = [c.changed_at[name] for c in cs]
            cells.append(f"{min(changed)} / {np.median(changed):.0f} / {max(changed)}")
        out.append(f"| {problems} | {len(cs)} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    args = problems_parser(__doc__).parse_args(argv)
    origins = {str(d): provenance(d) for d in args.dirs}
    rows = [c for d in args.dirs for c in changes(d)]
    header = (
        "# Closed rows changed from one step's problem to the next\n\n"
        f"A row is closed where the step leaves it within {CLOSED:g} (1 + |r dt|) m of its "
        "bound; each step's first displacement problem, solved by the native back-end.\n\n"
        + origins_list(origins)
    )
    write_table(
        args.out,
        header + table(rows),
        {"closed": CLOSED, "problems": origins, "rows": [asdict(c) for c in rows]},
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
