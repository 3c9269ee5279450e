"""The step problems of a native run solved again by independent QP solvers.

`python benches/walls/external_qp.py DIR [DIR ...] --out FILE.md` reads the files
`examples/wall_problems.rs` writes (`DIR/step-KKKK.json`: the problem a step starts with and the
native back-end's solutions of it, warm from the earlier steps and cold, with their times) and
solves each problem with Clarabel, PIQP, ProxQP, QPALM, OSQP and HiGHS, cold, and those whose
start works here (QPALM, OSQP) also warm, from the previous step's solution (its displacement,
and its multipliers matched by contact key). `make bench-walls-external-qp` runs it on the sliding
walls' ten pulse steps (docs/walls.md, "Independent QP solvers on a sliding wall's
steps").

The problem is the one the native back-ends solve (docs/FORMULATION, `StepProblem::scaled` and
`rows::edge_rows`): unknowns `u = dq / dt`, with `s = max(M) / theta`,

    min 1/2 u' P u + q' u   s.t.   D u + r >= 0,
    P = M / (theta s),  q = -(dt f + M v0 / theta) / s,
    D = [nrow + mu trow; nrow - mu trow],  r = (g_n ± mu g_t) / dt,

one pair of rows per contact point, the multipliers `z±` of the rows giving the forces
`N = (z+ + z-) s / dt` and `T = mu (z+ - z-) s / dt`. Each answer is judged in metres of the
step's displacement `dq = u dt`: its largest difference from the native solution and its
largest row violation `max(0, -(D dq + g))`; the solvers' agreement with the native displacement
is what checks the conversion. The JSON rows of the native solution also hold its stationarity
with its own forces and its complementarity (the accuracy of its multipliers).
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import queue
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
import scipy.sparse as sp

#: The tolerance every solver is asked for, on the scaled problem (absolute and relative where
#: the solver has both). The native back-end settles its rows to 1e-11 m.
TOLERANCE = 1e-9
#: Iteration limits generous enough that a solver stops on its tolerance, not its limit.
MAX_ITER = 200_000
#: A problem's time limit, s, for the solvers that take one (an answer after it is no answer).
TIME_LIMIT = 20.0
#: How long past `TIME_LIMIT` a child process may go without an answer before it is stopped (a
#: solver that does not honour its limit, or takes none).
ANSWER_MARGIN = 30.0
#: ProxQP takes no time limit: its outer iterations are capped instead (it takes 100-200 on
#: the 215-block wall's problems, about 15 ms each).
PROXQP_MAX_ITER = 2000


@dataclass
class Step:
    """One step's problem in the scaled form, and the native solution of it."""

    path: Path
    p: np.ndarray
    q: np.ndarray
    d: sp.csr_matrix
    #: `D` and `P` in the compressed-column form the solvers take (built before any timing).
    d_csc: sp.csc_matrix
    p_csc: sp.csc_matrix
    r: np.ndarray
    keys: np.ndarray
    #: Each contact point's friction coefficient (its rows are `2 k` and `2 k + 1`).
    mu: np.ndarray
    dt: float
    s: float
    native_u: np.ndarray
    native_z: np.ndarray
    native_ms: float
    native_factorisations: int
    #: The same problem solved by a native back-end that has solved nothing.
    cold_u: np.ndarray
    cold_ms: float
    cold_factorisations: int


def fail(path: Path, field: str, problem: str) -> NoReturn:
    sys.exit(f"error: {path}: {field}: {problem}")


def load_step(path: Path) -> Step:
    try:
        record = json.loads(path.read_text())
        pr, native = record["problem"], record["native"]
        cold = native["cold"]
        theta, dt = float(pr["theta"]), float(pr["dt"])
        mass = np.asarray(pr["mass"], float)
        force = np.asarray(pr["force"], float)
        v0 = np.asarray(pr["v0"], float)
        contacts = pr["contacts"]
    except (OSError, ValueError, KeyError, TypeError) as e:
        fail(path, "problem", f"not a step problem written by wall_problems ({e})")
    n = mass.size
    if not (theta > 0 and dt > 0 and n % 3 == 0 and force.size == n and v0.size == n):
        fail(path, "problem", f"{n} DOFs, theta {theta}, dt {dt}: not a step problem")
    s = mass.max() / theta
    p = mass / (theta * s)
    q = -(dt * force + mass * v0 / theta) / s
    rows, cols, vals, r, keys = [], [], [], [], []
    for k, c in enumerate(contacts):
        nrow, trow, mu = c["nrow"], c["trow"], float(c["mu"])
        for edge, sign in ((0, 1.0), (1, -1.0)):
            i = 2 * k + edge
            for (j, vn), (jt, vt) in zip(nrow, trow):
                if j != jt:
                    fail(path, f"contacts[{k}]", "normal and tangential rows on other DOFs")
                rows.append(i)
                cols.append(int(j))
                vals.append(vn + sign * mu * vt)
            r.append((c["g_n"] + sign * mu * c["g_t"]) / dt)
            keys.append((int(c["key"]) << 1) | edge)
    d = sp.csr_matrix((vals, (rows, cols)), shape=(2 * len(contacts), n))
    normal = np.asarray(native["normal"], float)
    tangential = np.asarray(native["tangential"], float)
    mus = np.array([float(c["mu"]) for c in contacts])
    # Edge multipliers from the forces: z+ + z- = N dt / s, z+ - z- = T dt / (mu s).
    with np.errstate(divide="ignore", invalid="ignore"):
        diff = np.where(mus > 0, tangential / mus, 0.0)
    z = np.empty(2 * len(contacts))
    z[0::2] = 0.5 * (normal + diff) * dt / s
    z[1::2] = 0.5 * (normal - diff) * dt / s
    return Step(
        path=path,
        p=p,
        q=q,
        d=d,
        d_csc=sp.csc_matrix(d),
        p_csc=sp.diags(p, format="csc"),
        r=np.asarray(r),
        keys=np.asarray(keys, dtype=np.uint64),
        mu=mus,
        dt=dt,
        s=s,
        native_u=np.asarray(native["dq"], float) / dt,
        native_z=z,
        native_ms=float(native["ms"]),
        native_factorisations=int(native["factorisations"]),
        cold_u=np.asarray(cold["dq"], float) / dt,
        cold_ms=float(cold["ms"]),
        cold_factorisations=int(cold["factorisations"]),
    )


def native_residuals(st: Step) -> tuple[float, float, float]:
    """The native solution's stationarity (in units of `q`), complementarity (m x multiplier
    scale) and largest row violation (m)."""
    u, z = st.native_u, st.native_z
    stationarity = st.p * u + st.q - st.d.T @ z
    slack = st.d @ u + st.r
    scale = max(1.0, float(np.abs(st.q).max()))
    return (
        float(np.abs(stationarity).max()) / scale,
        float(np.abs(slack * z).max()) * st.dt,
        float(max(0.0, -slack.min())) * st.dt,
    )


@dataclass
class Answer:
    u: np.ndarray | None
    z: np.ndarray | None
    ms: float
    iterations: int
    status: str


#: A start: the previous step's displacement and its multipliers on this step's rows.
Warm = tuple[np.ndarray, np.ndarray] | None
Solve = Callable[[Step, Warm], "Answer"]


def warm_multipliers(prev: Step | None, prev_z: np.ndarray | None, st: Step) -> np.ndarray:
    """The previous step's multipliers on this step's rows, by key (new rows start at 0)."""
    z = np.zeros(st.keys.size)
    if prev is None or prev_z is None:
        return z
    order = np.argsort(prev.keys)
    sorted_keys = prev.keys[order]
    at = np.searchsorted(sorted_keys, st.keys)
    at = np.minimum(at, sorted_keys.size - 1)
    hit = sorted_keys[at] == st.keys
    z[hit] = prev_z[order[at[hit]]]
    return z


def solve_clarabel(st: Step, _warm: Warm) -> Answer:
    import clarabel

    n = st.p.size
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.presolve_enable = False
    settings.tol_gap_abs = settings.tol_gap_rel = TOLERANCE
    settings.tol_feas = TOLERANCE
    settings.max_iter = 500
    settings.time_limit = TIME_LIMIT
    minus_d = -st.d_csc
    t0 = time.perf_counter()
    solver = clarabel.DefaultSolver(
        st.p_csc,
        st.q,
        minus_d,
        st.r,
        [clarabel.NonnegativeConeT(st.r.size)],
        settings,
    )
    sol = solver.solve()
    ms = (time.perf_counter() - t0) * 1e3
    ok = str(sol.status) in ("Solved", "AlmostSolved")
    return Answer(
        np.asarray(sol.x)[:n] if ok else None,
        np.asarray(sol.z) if ok else None,
        ms,
        int(sol.iterations),
        str(sol.status),
    )


def solve_piqp(st: Step, _warm: Warm) -> Answer:
    import piqp

    solver = piqp.SparseSolver()
    solver.settings.verbose = False
    solver.settings.eps_abs = TOLERANCE
    solver.settings.eps_rel = TOLERANCE
    solver.settings.max_iter = 500
    t0 = time.perf_counter()
    solver.setup(
        P=st.p_csc, c=st.q, G=st.d_csc, h_l=-st.r
    )
    status = solver.solve()
    ms = (time.perf_counter() - t0) * 1e3
    ok = status == piqp.PIQP_SOLVED
    res = solver.result
    return Answer(
        np.asarray(res.x) if ok else None,
        np.asarray(res.z_l) if ok else None,
        ms,
        int(res.info.iter),
        str(status),
    )


def solve_proxqp(st: Step, _warm: Warm) -> Answer:
    import proxsuite

    n, m = st.p.size, st.r.size
    qp = proxsuite.proxqp.sparse.QP(n, 0, m)
    qp.settings.eps_abs = TOLERANCE
    qp.settings.eps_rel = 0.0
    qp.settings.max_iter = PROXQP_MAX_ITER
    qp.settings.verbose = False
    t0 = time.perf_counter()
    qp.init(
        st.p_csc,
        st.q,
        None,
        None,
        st.d_csc,
        -st.r,
        np.full(m, 1e20),
    )
    qp.solve()
    ms = (time.perf_counter() - t0) * 1e3
    status = str(qp.results.info.status)
    ok = status.endswith("PROXQP_SOLVED")
    # ProxQP's multipliers of `l <= C x` are negative where the lower bound binds.
    return Answer(
        np.asarray(qp.results.x) if ok else None,
        -np.asarray(qp.results.z) if ok else None,
        ms,
        int(qp.results.info.iter),
        status.split(".")[-1],
    )


def solve_qpalm(st: Step, warm: Warm) -> Answer:
    import qpalm

    n, m = st.p.size, st.r.size
    data = qpalm.Data(n, m)
    data.Q = st.p_csc
    data.q = st.q
    data.A = st.d_csc
    data.bmin = -st.r
    data.bmax = np.full(m, 1e20)
    settings = qpalm.Settings()
    settings.eps_abs = TOLERANCE
    settings.eps_rel = TOLERANCE
    settings.max_iter = MAX_ITER
    settings.verbose = False
    settings.time_limit = TIME_LIMIT
    t0 = time.perf_counter()
    solver = qpalm.Solver(data, settings)
    if warm is not None:
        # QPALM's multipliers of a binding lower bound are negative.
        solver.warm_start(warm[0], -warm[1])
    solver.solve()
    ms = (time.perf_counter() - t0) * 1e3
    status = str(solver.info.status)
    ok = status == "solved"
    return Answer(
        np.asarray(solver.solution.x) if ok else None,
        -np.asarray(solver.solution.y) if ok else None,
        ms,
        int(solver.info.iter),
        status,
    )


def solve_osqp(st: Step, warm: Warm) -> Answer:
    import osqp

    m = st.r.size
    solver = osqp.OSQP()
    t0 = time.perf_counter()
    solver.setup(
        P=st.p_csc,
        q=st.q,
        A=st.d_csc,
        l=-st.r,
        u=np.full(m, np.inf),
        eps_abs=TOLERANCE,
        eps_rel=TOLERANCE,
        max_iter=MAX_ITER,
        polishing=True,
        time_limit=TIME_LIMIT,
        verbose=False,
    )
    if warm is not None:
        solver.warm_start(x=warm[0], y=-warm[1])
    res = solver.solve()
    ms = (time.perf_counter() - t0) * 1e3
    status = str(res.info.status)
    ok = status.startswith("solved")
    return Answer(
        np.asarray(res.x) if ok else None,
        -np.asarray(res.y) if ok else None,
        ms,
        int(res.info.iter),
        status,
    )


def solve_highs(st: Step, _warm: Warm) -> Answer:
    import highspy

    n, m = st.p.size, st.r.size
    h = highspy.Highs()  # type: ignore[no-untyped-call]
    h.setOptionValue("output_flag", False)
    h.setOptionValue("threads", 1)
    h.setOptionValue("time_limit", TIME_LIMIT)
    h.setOptionValue("qp_iteration_limit", MAX_ITER)
    h.setOptionValue("dual_feasibility_tolerance", TOLERANCE)
    h.setOptionValue("primal_feasibility_tolerance", TOLERANCE)
    model = highspy.HighsModel()
    lp = model.lp_
    lp.num_col_ = n
    lp.num_row_ = m
    lp.col_cost_ = st.q
    lp.col_lower_ = np.full(n, -highspy.kHighsInf)
    lp.col_upper_ = np.full(n, highspy.kHighsInf)
    lp.row_lower_ = -st.r
    lp.row_upper_ = np.full(m, highspy.kHighsInf)
    a = st.d_csc
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_ = a.indptr
    lp.a_matrix_.index_ = a.indices
    lp.a_matrix_.value_ = a.data
    hess = model.hessian_
    hess.dim_ = n
    hess.format_ = highspy.HessianFormat.kTriangular
    hess.start_ = np.arange(n + 1)
    hess.index_ = np.arange(n)
    hess.value_ = st.p
    t0 = time.perf_counter()
    h.passModel(model)
    h.run()
    ms = (time.perf_counter() - t0) * 1e3
    status = h.modelStatusToString(h.getModelStatus())
    ok = status == "Optimal"
    sol = h.getSolution()
    info = h.getInfo()
    return Answer(
        np.asarray(sol.col_value) if ok else None,
        np.asarray(sol.row_dual) if ok else None,
        ms,
        int(info.qp_iteration_count),
        status,
    )


#: (name, solve, takes a warm start)
SOLVERS: list[tuple[str, Solve, bool]] = [
    ("Clarabel", solve_clarabel, False),
    ("PIQP", solve_piqp, False),
    # ProxQP's warm start (`InitialGuess.WARM_START`, the previous step's displacement and
    # multipliers) did not return within 100 s on the 215-block wall's second problem, even
    # with its iterations capped at 50: it is run cold only.
    ("ProxQP", solve_proxqp, False),
    ("QPALM", solve_qpalm, True),
    ("OSQP", solve_osqp, True),
    ("HiGHS", solve_highs, False),
]


def judge(st: Step, ans: Answer) -> tuple[float, float]:
    """An answer's largest difference from the native displacement, and its largest row
    violation, both in metres."""
    if ans.u is None:
        return math.nan, math.nan
    diff = float(np.abs(ans.u - st.native_u).max()) * st.dt
    violation = float(max(0.0, -(st.d @ ans.u + st.r).min())) * st.dt
    return diff, violation


def solve_in_turn(files: list[Path], solve: Solve, warm: bool, results: Any) -> None:
    """A child process: solve the problems of `files` in turn, each answer (or an error) put
    on `results` as it comes."""
    prev, prev_ans = None, None
    for f in files:
        st = load_step(f)
        start = None
        if warm and prev is not None and prev_ans is not None and prev_ans.u is not None:
            if prev.p.size == st.p.size:
                start = (prev_ans.u, warm_multipliers(prev, prev_ans.z, st))
        try:
            ans = solve(st, start)
        except Exception as e:  # noqa: BLE001 - a solver's failure is that problem's answer
            ans = Answer(None, None, math.nan, 0, f"error: {e}")
        diff, violation = judge(st, ans)
        results.put((ans.status, ans.iterations, ans.ms, diff, violation))
        prev, prev_ans = st, ans


def row(
    st: Step,
    directory: Path,
    solver: str,
    status: str,
    iterations: int,
    ms: float,
    diff: float,
    violation: float,
) -> dict[str, Any]:
    return {
        "problems": directory.name,
        "step": st.path.stem,
        "dofs": st.p.size,
        "rows": st.r.size,
        "solver": solver,
        "status": status,
        "iterations": iterations,
        "ms": ms,
        "difference_m": diff,
        "violation_m": violation,
    }


def problems_parser(doc: str) -> argparse.ArgumentParser:
    """The command line the wall-problem benchmarks share: directories of problems, `--out`."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("dirs", nargs="+", type=Path, help="directories of step-KKKK.json")
    ap.add_argument("--out", type=Path, required=True, help="the markdown table (and .json beside)")
    return ap


def write_table(out: Path, markdown: str, record: dict[str, Any]) -> None:
    """`out` (markdown) and the JSON beside it, each written whole under a `.partial` name and
    then renamed, so an interrupted run leaves no half-written table; the table is printed."""
    out.parent.mkdir(parents=True, exist_ok=True)
    json_out = out.with_suffix(".json")
    json_partial = json_out.with_suffix(".json.partial")
    md_partial = out.with_suffix(".md.partial")
    json_partial.write_text(json.dumps(record, indent=1))
    md_partial.write_text(markdown)
    json_partial.rename(json_out)
    md_partial.rename(out)
    print(out.read_text())


def provenance(directory: Path) -> dict[str, Any]:
    """What produced a directory's problems (`wall_problems`' `provenance.json`: its command,
    versions and machine, the scene and the native settings)."""
    path = directory / "provenance.json"
    try:
        record = json.loads(path.read_text())
        for part, field in (("provenance", "rockbench_version"), ("native_settings", "dt")):
            if field not in record[part]:
                raise KeyError(f"{part}.{field}")
    except (OSError, ValueError, KeyError, TypeError) as e:
        fail(path, "provenance", f"not the provenance wall_problems writes ({e})")
    return dict(record)


def origins_list(origins: dict[str, dict[str, Any]]) -> str:
    """What produced each directory of problems, a line each (for a table's header)."""
    return (
        "Problems (each directory's `provenance.json` has the whole of it):\n"
        + "".join(
            f"- {d}: `{o['scene']}`, rockbench {o['provenance']['rockbench_version']} "
            f"({o['provenance']['git_commit']}), native dt {o['native_settings']['dt']}, "
            f"locate_impacts {json.dumps(o['native_settings'].get('locate_impacts'))}\n"
            for d, o in origins.items()
        )
        + "\n"
    )


def run(dirs: list[Path], names: set[str] | None) -> list[dict[str, Any]]:
    """Every solver on every set of problems, each solver's sequence in a child process: a
    problem that has no answer `TIME_LIMIT + ANSWER_MARGIN` s after the last one stops the
    child, and the rest of that set counts as not run for that solver."""
    ctx = multiprocessing.get_context("fork")
    rows = []
    for directory in dirs:
        files = sorted(directory.glob("step-*.json"))
        if not files:
            fail(directory, "step-*.json", "no step problems (written by wall_problems)")
        steps = [load_step(f) for f in files]
        for name, solve, takes_warm in SOLVERS:
            if names is not None and name not in names:
                continue
            for warm in (False, True) if takes_warm else (False,):
                solver = name + (" (warm)" if warm else "")
                results = ctx.Queue()
                child = ctx.Process(target=solve_in_turn, args=(files, solve, warm, results))
                child.start()
                over = False
                for st in steps:
                    if over:
                        rows.append(row(st, directory, solver, "not run (an earlier problem "
                                        "over the time limit)", 0, math.nan, math.nan, math.nan))
                        continue
                    try:
                        answer = results.get(timeout=TIME_LIMIT + ANSWER_MARGIN)
                        status, its, ms, diff, violation = answer
                    except queue.Empty:
                        child.kill()
                        over = True
                        rows.append(row(st, directory, solver, "no answer within the time limit",
                                        0, math.nan, math.nan, math.nan))
                        continue
                    if ms > 1e3 * TIME_LIMIT:
                        over = True
                        status = f"{status}, over the time limit"
                        diff, violation = math.nan, math.nan
                    rows.append(row(st, directory, solver, status, its, ms, diff, violation))
                    print(
                        f"{directory.name} {st.path.stem} {solver}: {status}, {its} iterations, "
                        f"{ms:.1f} ms, {diff:.1e} m from native",
                        file=sys.stderr,
                    )
                child.kill()
                child.join()
        for st in steps:
            stat, comp, viol = native_residuals(st)
            r = row(st, directory, "native (warm, as in the run)", "solved",
                    st.native_factorisations, st.native_ms, 0.0, viol)
            r["stationarity"], r["complementarity_m"] = stat, comp
            rows.append(r)
        for st in steps:
            cold = Answer(st.cold_u, None, st.cold_ms, st.cold_factorisations, "solved")
            diff, viol = judge(st, cold)
            rows.append(
                row(st, directory, "native (cold)", "solved", st.cold_factorisations,
                    st.cold_ms, diff, viol)
            )
    return rows


def metres(x: float) -> str:
    return "-" if math.isnan(x) else f"{x:.1e}"


def table(rows: list[dict[str, Any]]) -> str:
    """Per set of problems and solver: solved count, median and largest time, median
    iterations, largest difference from native and largest violation."""
    out = [
        "| problems | DOFs | rows | solver | solved | ms a problem, median (largest) "
        "| iterations, median | largest difference from native, m | largest row violation, m |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["problems"], r["solver"]), []).append(r)
    for (problems, solver), rs in groups.items():
        solved = [r for r in rs if not math.isnan(r["difference_m"])]
        ran = [r for r in rs if not math.isnan(r["ms"])]
        ms = np.array([r["ms"] for r in ran])
        its = np.array([r["iterations"] for r in ran])
        diff = max((r["difference_m"] for r in solved), default=math.nan)
        viol = max((r["violation_m"] for r in solved), default=math.nan)
        what = "factorisations" if solver.startswith("native") else ""
        rows_range = f"{min(r['rows'] for r in rs)}-{max(r['rows'] for r in rs)}"
        if ran:
            cost = f"{np.median(ms):.1f} ({ms.max():.1f}) | {np.median(its):.0f} {what}".rstrip()
        else:
            cost = "- | -"
        out.append(
            f"| {problems} | {rs[0]['dofs']} | {rows_range} | {solver} "
            f"| {len(solved)} of {len(rs)} "
            f"| {cost} | {metres(diff)} | {metres(viol)} |"
        )
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = problems_parser(__doc__)
    ap.add_argument("--solvers", help="comma-separated names (default: all; empty: none)")
    args = ap.parse_args(argv)
    # `--solvers ""`: none, the native solutions alone.
    names = None if args.solvers is None else {n for n in args.solvers.split(",") if n}
    if names is not None:
        unknown = names - {n for n, _, _ in SOLVERS}
        if unknown:
            known = [n for n, _, _ in SOLVERS]
            sys.exit(f"error: --solvers: unknown {sorted(unknown)}; known: {known}")
    origins = {str(d): provenance(d) for d in args.dirs}
    rows = run(args.dirs, names)
    versions = {}
    for module in ("clarabel", "piqp", "proxsuite", "qpalm", "osqp", "highspy", "numpy", "scipy"):
        try:
            from importlib.metadata import version

            versions[module] = version(module)
        except Exception:  # noqa: BLE001 - a missing package is recorded as such
            versions[module] = "not installed"
    header = (
        "# Independent QP solvers on the native engine's step problems\n\n"
        f"Tolerance asked of each: {TOLERANCE:g} on the scaled problem; one thread; times are "
        "setup and solve, in this process.\nVersions: "
        + ", ".join(f"{k} {v}" for k, v in versions.items())
        + "\n\n"
        + origins_list(origins)
    )
    write_table(
        args.out,
        header + table(rows),
        {"versions": versions, "tolerance": TOLERANCE, "problems": origins, "rows": rows},
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
