"""What sets an interior point's iteration count on a moving wall's step problems.

`python benches/walls/ipm_rows.py DIR [DIR ...] --out FILE.md` reads the step problems
`examples/wall_problems.rs` writes (`DIR/step-KKKK.json`, read by `external_qp.load_step`: `min
1/2 u'Pu + q'u s.t. D u + r >= 0`, rows `2 k` and `2 k + 1` the two cone edges `n +- mu t` of
contact point `k`) and solves each again with Clarabel, cold, in five forms:

- the whole problem;
- without its closed rows that carry no force;
- without its open rows;
- with its loaded rows alone;
- with the interfaces lifted: the points of one pair of blocks with the same tangential offset
  share one unknown `a >= |t u + g_t|` on their mean tangential row, and each point keeps the
  row `n_i u + g_n,i - mu a >= 0`. Where the points' tangential rows agree this is the vertex
  law (`n_i u + g_n,i >= mu |t u + g_t|`), with rows independent at a sticking interface (four
  on the interface's three relative DOFs and `a`) and unique multipliers.

The rows are classified at the whole problem's solution to `TIGHT`: closed where the slack is
below the multiplier, loaded where the multiplier is above `LOADED` of the largest. A row left
out with a zero multiplier leaves the minimiser of the strictly convex QP where it was, so the
three reduced forms have the whole problem's answer: what changes is only the iterations. Each
form is solved at each of `TOLERANCES`; its answer is judged in metres of the step's
displacement against the whole problem's, and by the largest violation of any of the whole
problem's rows. `make bench-walls-ipm-rows` runs it on the sliding walls' ten pulse steps
(docs/walls.md, "What sets the interior point's count on a sliding wall").
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).resolve().parent))
from external_qp import (  # noqa: E402
    Step,
    fail,
    load_step,
    origins_list,
    problems_parser,
    provenance,
    write_table,
)

#: The tolerance of the solve whose solution classifies the rows (Clarabel's gap and
#: feasibility tolerances on the scaled problem).
TIGHT = 1e-11
#: The tolerances every form is solved at.
TOLERANCES = (1e-9, 1e-11)
#: A closed row is loaded where its multiplier is above this fraction of the largest.
LOADED = 1e-6
#: Points of one pair of blocks share a tangential offset when their offsets (in the units of
#: `r`, m/s) differ by less than this.
SAME_OFFSET = 1e-12
#: Iterations and seconds allowed a solve: enough that a solve stops on its tolerance.
MAX_ITER = 500
TIME_LIMIT = 20.0

#: A problem `(P diagonal, q, D, r)`: `min 1/2 x'Px + q'x s.t. D x + r >= 0`.
Problem = tuple[np.ndarray, np.ndarray, sp.csr_matrix, np.ndarray]


def classify(slack: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The closed rows (slack below multiplier) and, of them, the loaded ones (multiplier above
    `LOADED` of the largest), from a solution's slacks and multipliers."""
    closed = slack < z
    loaded = closed & (z > LOADED * max(float(z.max()), 0.0))
    return closed, loaded


def reduced(st: Step, keep: np.ndarray) -> Problem:
    """The step's problem with the rows `keep` only."""
    return st.p, st.q, st.d[keep], st.r[keep]


def interfaces(st: Step) -> list[list[int]]:
    """The contact points grouped by pair of blocks and tangential offset, in order of their
    first point: the groups whose points may share one tangential unknown."""
    offsets = tangential_offsets(st)
    groups: dict[frozenset[int], list[list[int]]] = {}
    ordered: list[list[int]] = []
    for k in range(st.mu.size):
        lo, hi = st.d.indptr[2 * k], st.d.indptr[2 * k + 1]
        pair = frozenset(int(j) // 3 for j in st.d.indices[lo:hi])
        for g in groups.setdefault(pair, []):
            if abs(offsets[g[0]] - offsets[k]) < SAME_OFFSET:
                g.append(k)
                break
        else:
            groups[pair].append([k])
            ordered.append(groups[pair][-1])
    return ordered


def tangential_offsets(st: Step) -> np.ndarray:
    """Each point's tangential offset `g_t / dt` from its two edge rows' offsets."""
    plus, minus = st.r[0::2], st.r[1::2]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(st.mu > 0, (plus - minus) / (2 * st.mu), 0.0)


def lifted(st: Step, groups: list[list[int]]) -> Problem:
    """The step's problem with one unknown `a >= |t u + g_t|` a group of points (after the
    DOFs), the group's mean tangential row `t`, and each point's row `n_i u + g_n,i - mu a >=
    0`. A frictionless point keeps its rows."""
    n = st.p.size
    d = st.d.tocsr()
    gt = tangential_offsets(st)
    rows: list[int] = []
    cols: list[int] = []
    vals: list[float] = []
    offsets: list[float] = []

    def put(entries: dict[int, float], offset: float) -> None:
        i = len(offsets)
        for j, v in entries.items():
            rows.append(i)
            cols.append(j)
            vals.append(v)
        offsets.append(offset)

    def edge(i: int) -> dict[int, float]:
        lo, hi = d.indptr[i], d.indptr[i + 1]
        return dict(zip(d.indices[lo:hi].tolist(), d.data[lo:hi].tolist(), strict=True))

    extra = 0
    for g in groups:
        mu = float(st.mu[g[0]])
        if mu <= 0.0:
            for k in g:
                put(edge(2 * k), float(st.r[2 * k]))
                put(edge(2 * k + 1), float(st.r[2 * k + 1]))
            continue
        a = n + extra
        extra += 1
        t: dict[int, float] = {}
        for k in g:
            plus, minus = edge(2 * k), edge(2 * k + 1)
            for j in plus | minus:
                t[j] = t.get(j, 0.0) + (plus.get(j, 0.0) - minus.get(j, 0.0)) / (2 * mu * len(g))
        offset = float(np.mean(gt[g]))
        for sign in (1.0, -1.0):
            put({**{j: sign * v for j, v in t.items()}, a: 1.0}, sign * offset)
        for k in g:
            plus, minus = edge(2 * k), edge(2 * k + 1)
            normal = {j: (plus.get(j, 0.0) + minus.get(j, 0.0)) / 2 for j in plus | minus}
            put({**normal, a: -mu}, 0.5 * float(st.r[2 * k] + st.r[2 * k + 1]))
    lifted_d = sp.csr_matrix((vals, (rows, cols)), shape=(len(offsets), n + extra))
    return (
        np.concatenate([st.p, np.zeros(extra)]),
        np.concatenate([st.q, np.zeros(extra)]),
        lifted_d,
        np.asarray(offsets),
    )


@dataclass
class Solved:
    """One solve: the unknowns, the multipliers, the iterations and the solver's status."""

    x: np.ndarray
    z: np.ndarray
    iterations: int
    status: str


def clarabel(problem: Problem, tolerance: float) -> Solved:
    """Clarabel, cold, presolve off, on `-D x + s = r, s >= 0`."""
    import clarabel as cl

    p, q, d, r = problem
    settings = cl.DefaultSettings()
    settings.verbose = False
    settings.presolve_enable = False
    settings.tol_gap_abs = settings.tol_gap_rel = tolerance
    settings.tol_feas = tolerance
    settings.max_iter = MAX_ITER
    settings.time_limit = TIME_LIMIT
    sol = cl.DefaultSolver(
        sp.diags(p, format="csc"), q, -sp.csc_matrix(d), r, [cl.NonnegativeConeT(r.size)], settings
    ).solve()
    return Solved(np.asarray(sol.x), np.asarray(sol.z), int(sol.iterations), str(sol.status))


#: A solver of a problem to a tolerance.
Solve = Callable[[Problem, float], Solved]


@dataclass
class Row:
    """One problem's rows and, for each form, iterations and status at each tolerance and
    the answer's distance from the whole problem's (m) and largest violation of its rows (m)."""

    problems: str
    step: str
    rows: int
    closed: int
    unloaded: int
    open: int
    groups: int
    forms: dict[str, dict[str, Any]] = field(default_factory=dict)


#: The forms, in the table's order.
FORMS = ("whole", "without unloaded closed", "without open", "loaded alone", "lifted")


def study(st: Step, solve: Solve) -> Row:
    """Every form of one step's problem, solved at every tolerance."""
    ref = solve((st.p, st.q, st.d, st.r), TIGHT)
    if ref.status not in ("Solved", "AlmostSolved"):
        fail(st.path, "problem", f"the classifying solve ended {ref.status}")
    u = ref.x[: st.p.size]
    closed, loaded = classify(st.d @ u + st.r, ref.z)
    groups = interfaces(st)
    forms: dict[str, Problem] = {
        "whole": (st.p, st.q, st.d, st.r),
        "without unloaded closed": reduced(st, ~closed | loaded),
        "without open": reduced(st, closed),
        "loaded alone": reduced(st, loaded),
        "lifted": lifted(st, groups),
    }
    row = Row(
        problems=st.path.parent.name,
        step=st.path.stem,
        rows=int(st.r.size),
        closed=int(closed.sum()),
        unloaded=int((closed & ~loaded).sum()),
        open=int((~closed).sum()),
        groups=len(groups),
    )
    for name, problem in forms.items():
        out: dict[str, Any] = {}
        for tol in TOLERANCES:
            s = solve(problem, tol)
            x = s.x[: st.p.size]
            out[f"{tol:g}"] = {
                "iterations": s.iterations,
                "status": s.status,
                "distance_m": float(np.abs(x - u).max()) * st.dt,
                "violation_m": float(max(0.0, -(st.d @ x + st.r).min())) * st.dt,
            }
        row.forms[name] = out
        done = ", ".join(f"{k} {v['iterations']} {v['status']}" for k, v in out.items())
        print(f"{row.problems} {row.step} {name}: {done}", file=sys.stderr, flush=True)
    return row


def cell(result: dict[str, Any]) -> str:
    """Iterations, marked where the solve did not end `Solved`."""
    mark = "" if result["status"] == "Solved" else f" ({result['status']})"
    return f"{result['iterations']}{mark}"


def table(rows: list[Row]) -> str:
    """One line a problem: its rows, and each form's iterations at each tolerance."""
    tols = " / ".join(f"{t:g}" for t in TOLERANCES)
    out = [
        "| problems | step | rows: closed (unloaded); open | groups | "
        + " | ".join(FORMS)
        + " | largest distance / violation of the reduced and lifted forms, m |",
        "|---|---|---|---|" + "---|" * len(FORMS) + "---|",
    ]
    for r in rows:
        cells = [" / ".join(cell(r.forms[f][f"{t:g}"]) for t in TOLERANCES) for f in FORMS]
        reduced_forms = [f for f in FORMS if f != "whole"]
        dist = max(r.forms[f][k]["distance_m"] for f in reduced_forms for k in r.forms[f])
        viol = max(r.forms[f][k]["violation_m"] for f in reduced_forms for k in r.forms[f])
        out.append(
            f"| {r.problems} | {r.step} | {r.rows}: {r.closed} ({r.unloaded}); {r.open} | "
            f"{r.groups} | " + " | ".join(cells) + f" | {dist:.1e} / {viol:.1e} |"
        )
    head = f"Iterations at tolerances {tols} (Clarabel, cold, presolve off).\n\n"
    return head + "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    args = problems_parser(__doc__).parse_args(argv)
    origins = {str(d): provenance(d) for d in args.dirs}
    rows: list[Row] = []
    for d in args.dirs:
        files = sorted(d.glob("step-*.json"))
        if not files:
            fail(d, "step-*.json", "no step problems (written by wall_problems)")
        rows.extend(study(load_step(f), clarabel) for f in files)
    header = (
        "# What sets an interior point's iteration count on a moving wall's problems\n\n"
        f"Rows classified at Clarabel's solution to {TIGHT:g}: closed where the slack is below "
        f"the multiplier, loaded where the multiplier is above {LOADED:g} of the largest.\n\n"
        + origins_list(origins)
    )
    write_table(
        args.out,
        header + table(rows),
        {
            "tight": TIGHT,
            "tolerances": TOLERANCES,
            "loaded": LOADED,
            "problems": origins,
            "rows": [asdict(r) for r in rows],
        },
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
