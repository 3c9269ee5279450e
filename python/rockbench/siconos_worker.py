"""Worker of the Siconos engine: a rockbench scene as a Siconos nonsmooth dynamical system.

    SICONOS_PYTHON siconos_worker.py --input INPUT.json --out DIR [--source NAME]

Siconos (Debian's ``python3-siconos``) is built against numpy 1.x and runs under its own
interpreter (``make siconos``), not rockbench's ``.venv``: this file is a standalone script that
imports only the standard library, numpy and siconos, never the ``rockbench`` package. The Rust
harness (``src/engines/external.rs``) writes it next to ``INPUT.json``: the scene as
``Scene::to_json()`` plus what only the Rust side computes (``layout``: the initial state of
every block; ``supports``; ``friction_below``; ``ground``: the ground velocity at every step
boundary, from which the exact mean ground acceleration of each step follows). It writes
``DIR/trajectory.csv`` and ``DIR/summary.json`` like ``rockbench.worker``, and on failure one
line to stderr with exit code 2 (bad setting), 3 (missing package), 4 (NaN) or 1.

The model (the nonsmooth contact dynamics recipe of ENGINES.md): all blocks form one
``LagrangianLinearTIDS`` with q = (x, z, phi) per block, M = diag(m, m, I), gravity and the
ground motion as an external force (inertial forces -m a_g, so the trajectory is relative to
the ground). Every corner that can touch a face (a bottom corner on the ground or on the top
of the block below, a top corner of the block below on the bottom of the block above) is an
``Interaction`` with a two-row relation (gap along the face's normal, position along it) and a
``NewtonImpactFrictionNSL(e, 0, mu, 2)`` with the interface's friction. Time-stepping is
Moreau-Jean (``theta``) with a 2D friction-contact problem, or its direct-projection variant,
which also projects positions onto the constraints (no pivot sink). A duration that is not a
whole number of steps ends with one shorter step (an event at the duration inserted into the
events manager), so the last sample is at the duration as in the native engine; the input then
gives the ground velocity at the duration too, and that step takes its own mean acceleration.

Settings (the ``[siconos]`` table; defaults measured against Housner, docs/engines-siconos.md):
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
import traceback
from typing import Any, Callable

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy: threaded BLAS only costs here

try:
    import numpy as np
except ImportError as _e:  # the worker runs under the Siconos interpreter, which has numpy 1.x
    print(
        f"cannot import numpy ({_e}) with {sys.executable}: run `make siconos` (Debian's "
        "python3-siconos in a venv of /usr/bin/python3), or set ROCKBENCH_SICONOS_PYTHON",
        file=sys.stderr,
    )
    sys.exit(3)

FIELDS = ("x", "z", "phi", "vx", "vz", "omega")


class WorkerError(Exception):
    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code


def _positive(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise WorkerError(2, f"{name}: must be a positive number (got {v!r})")
    return float(v)


def _unit(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 <= v <= 1.0:
        raise WorkerError(2, f"{name}: must be a number in [0, 1] (got {v!r})")
    return float(v)


def _half_to_one(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.5 <= v <= 1.0:
        raise WorkerError(2, f"{name}: must be a number in [0.5, 1] (got {v!r})")
    return float(v)


# The largest value of a C int: Siconos' solver options hold the iteration count as one.
MAX_C_INT = 2**31 - 1


def _positive_int(name: str, v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= MAX_C_INT:
        raise WorkerError(
            2, f"{name}: must be a whole number from 1 to {MAX_C_INT} (a C int) (got {v!r})"
        )
    return v


def _relative_residual(name: str, v: Any) -> float:
    if (
        isinstance(v, bool)
        or not isinstance(v, (int, float))
        or not math.isfinite(v)
        or not 0 < v < 1
    ):
        raise WorkerError(2, f"{name}: must be a relative residual, > 0 and < 1 (got {v!r})")
    return float(v)


def _one_of(*choices: str) -> Callable[[str, Any], str]:
    def check(name: str, v: Any) -> str:
        if v not in choices:
            raise WorkerError(2, f"{name}: must be one of {', '.join(choices)} (got {v!r})")
        return str(v)

    return check


# name: (default, check, meaning). The Rust harness reads `step` (to sample the ground motion)
# and `timeout` itself; src/engines/external.rs holds the same defaults (a test compares them).
SETTINGS: dict[str, tuple[Any, Callable[[str, Any], Any], str]] = {
    "step": (1e-4, _positive, "Time step h of the Moreau-Jean scheme, s."),
    "theta": (0.5, _half_to_one, "Moreau-Jean theta (0.5: midpoint, 1: backward Euler)."),
    "scheme": (
        "projection",
        _one_of("projection", "plain"),
        "plain: MoreauJeanOSI + TimeStepping (velocity level only; corners sink by up to "
        "h/2 x impact velocity); projection: MoreauJeanDirectProjectionOSI + "
        "TimeSteppingDirectProjection, positions also projected onto the constraints.",
    ),
    "restitution": (
        0.0,
        _unit,
        "Newton impact coefficient e of every contact (0: Housner's restitution comes from "
        "the geometry; the rocking coefficient is not a contact restitution).",
    ),
    "solver": (
        "NSGS",
        _one_of("NSGS", "ENUM", "LEMKE", "CPG"),
        "2D friction-contact solver (SICONOS_FRICTION_2D_*).",
    ),
    "tolerance": (
        1e-12,
        _relative_residual,
        "Tolerance of the friction-contact solver, a relative residual (Siconos' error of the "
        "friction-contact problem divided by the norm of its q), > 0 and < 1 (1 or more accepts "
        "any iterate, even no contact force).",
    ),
    "iterations": (
        1000,
        _positive_int,
        "Largest number of solver iterations per step, 1 to 2^31 - 1 (a C int).",
    ),
    "timeout": (
        600.0,
        _positive,
        "Wall-clock limit of one worker run, s: past it the harness kills the worker "
        "(read by the Rust harness, recorded here).",
    ),
}

__doc__ = (__doc__ or "") + "".join(
    f"``{k}`` {d!r}: {m}\n" for k, (d, _, m) in SETTINGS.items()
)


def read_settings(given: Any) -> dict[str, Any]:
    """The ``[siconos]`` table checked, with defaults filled in."""
    if given is None:
        given = {}
    if not isinstance(given, dict):
        raise WorkerError(2, f"siconos: must be a table of settings (got {given!r})")
    unknown = sorted(set(given) - set(SETTINGS))
    if unknown:
        raise WorkerError(
            2, f"siconos.{unknown[0]}: unknown setting (known: {', '.join(sorted(SETTINGS))})"
        )
    out = {}
    for name, (default, check, _) in SETTINGS.items():
        out[name] = check(f"siconos.{name}", given[name]) if name in given else default
    return out


def siconos_version() -> str:
    import siconos

    v = f"siconos {getattr(siconos, 'version', '?')}"
    try:
        deb = subprocess.run(
            ["dpkg-query", "-W", "-f=${Version}", "python3-siconos"],
            capture_output=True,
            text=True,
            timeout=10,
            check=False,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        deb = ""
    return f"{v} (Debian python3-siconos {deb})" if deb else v


def rot(phi: float) -> tuple[float, float, float, float]:
    c, s = math.cos(phi), math.sin(phi)
    return c, s, -s, c  # columns: R e_x = (c, s), R e_z = (-s, c)


class Contact:
    """A point of body ``p`` (local ``r``) against the face of body ``f`` (None: the ground)
    at local height ``sigma * hf`` with outward normal ``sigma * R(phi_f) e_z``."""

    def __init__(
        self, p: int, r: tuple[float, float], f: int | None, sigma: float, hf: float, mu: float
    ) -> None:
        self.p, self.r, self.f, self.sigma, self.hf, self.mu = p, r, f, sigma, hf, mu

    def evaluate(self, q: Any, jac: Any | None) -> tuple[float, float]:
        """Gap and tangential position; writes the 2 x 3n Jacobian into ``jac`` if given."""
        i = 3 * self.p
        x, z, ph = q[i], q[i + 1], q[i + 2]
        c, s = math.cos(ph), math.sin(ph)
        rx, rz = self.r
        px, pz = x + c * rx - s * rz, z + s * rx + c * rz
        dpx, dpz = -s * rx - c * rz, c * rx - s * rz  # d p / d phi_p
        if self.f is None:
            nx, nz, tx, tz, fx, fz = 0.0, 1.0, 1.0, 0.0, 0.0, 0.0
        else:
            j = 3 * self.f
            cf, sf = math.cos(q[j + 2]), math.sin(q[j + 2])
            tx, tz = cf, sf
            nx, nz = -self.sigma * sf, self.sigma * cf
            fx = q[j] - sf * self.sigma * self.hf
            fz = q[j + 1] + cf * self.sigma * self.hf
        dx, dz = px - fx, pz - fz
        g = nx * dx + nz * dz
        t = tx * dx + tz * dz
        if jac is not None:
            jac[:, :] = 0.0
            jac[0, i : i + 3] = (nx, nz, nx * dpx + nz * dpz)
            jac[1, i : i + 3] = (tx, tz, tx * dpx + tz * dpz)
            if self.f is not None:
                j = 3 * self.f
                jac[0, j : j + 3] = (-nx, -nz, -self.sigma * t)
                jac[1, j : j + 3] = (-tx, -tz, self.sigma * (g + self.hf))
        return g, t


def contacts(spec: dict[str, Any], supports: list[int | None], friction: list[float]) -> list[Contact]:
    """Every corner-face pair that can touch: each block's bottom corners on its support's top
    (or the ground), and the support's top corners on the block's bottom where they lie under
    it (corners at the same place are taken once)."""
    blocks = spec["blocks"]
    out: list[Contact] = []
    for a, b in enumerate(blocks):
        ba, ha = b["width"] / 2, b["height"] / 2
        s = supports[a]
        mu = friction[a]
        if s is None:
            for sx in (-1.0, 1.0):
                out.append(Contact(a, (sx * ba, -ha), None, 1.0, 0.0, mu))
            continue
        bs, hs = blocks[s]["width"] / 2, blocks[s]["height"] / 2
        off = b.get("offset", 0.0)  # centre of a relative to s, upright
        for sx in (-1.0, 1.0):
            cx = off + sx * ba  # a's bottom corner in s's frame
            if -bs - 1e-12 <= cx <= bs + 1e-12:
                out.append(Contact(a, (sx * ba, -ha), s, 1.0, hs, mu))
        for sx in (-1.0, 1.0):
            cx = sx * bs - off  # s's top corner in a's frame
            if -ba + 1e-12 < cx < ba - 1e-12:
                out.append(Contact(s, (sx * bs, hs), a, -1.0, ha, mu))
    return out


def unsupported(spec: dict[str, Any], supports: list[int | None]) -> str | None:
    for i, b in enumerate(spec["blocks"]):
        if b.get("x") is not None:
            return f"block `{b['name']}` is placed by absolute `x` (walls): not modelled"
        if i > 0 and supports[i] != i - 1:
            return f"block `{b['name']}` does not rest on the block below it: not modelled"
    return None


# A duration within this fraction of a step of a whole number of steps is that whole number
# (the native engine's rule, src/engines/native.rs; rockbench.engines.common.time_grid).
WHOLE_STEP_TOLERANCE = 1e-9


def time_grid(
    duration: float, output_interval: float, step: float
) -> tuple[int, list[int], float]:
    """Steps, the step indices of the samples (every ``output_interval`` rounded to whole
    steps, and the last step) and the length of the last step: ``step``, or the rest of the
    duration when it is not a whole number of steps (the last step ends at the duration)."""
    n_total = max(1, math.ceil(duration / step - WHOLE_STEP_TOLERANCE))
    last = duration - (n_total - 1) * step
    if abs(last / step - 1.0) <= WHOLE_STEP_TOLERANCE:
        last = step
    every = max(1, round(output_interval / step))
    return n_total, list(range(0, n_total, every)) + [n_total], last


# Depth past which a corner inside another body, or below the ground, means the run has left
# the model: the worker's contacts are each block's base corners on the face below and the top
# corners of the block below on its base, so a block that overturns (its side on the ground, a
# corner on another block's side) has none where it lands and passes through. The modelled
# contacts keep their penetration at round-off; this is a fraction of the bodies' smallest side.
MODEL_DEPTH_FRACTION = 0.05


def corners(states: Any, blocks: list[dict[str, Any]]) -> Any:
    """Corners of every block at every sample: (samples, blocks, 4, 2), from the states'
    (x, z, phi) columns."""
    half = np.array([[b["width"] / 2, b["height"] / 2] for b in blocks])
    signs = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    local = signs[None, :, :] * half[:, None, :]  # (blocks, 4, 2)
    x, z, ph = states[:, :, 0], states[:, :, 1], states[:, :, 2]
    c, s = np.cos(ph)[:, :, None], np.sin(ph)[:, :, None]
    rx, rz = local[None, :, :, 0], local[None, :, :, 1]
    return np.stack([x[:, :, None] + c * rx - s * rz, z[:, :, None] + s * rx + c * rz], axis=-1)


def left_model(t: Any, states: Any, blocks: list[dict[str, Any]]) -> tuple[float, str] | None:
    """The first sample at which a corner lies deeper than ``MODEL_DEPTH_FRACTION`` of the
    smaller body's smallest side inside another block or below the ground, and what it is;
    None if the run stays in the model throughout."""
    pts = corners(states, blocks)
    smallest = np.array([min(b["width"], b["height"]) for b in blocks])
    first: tuple[int, str] | None = None

    def found(k: int, what: str) -> None:
        nonlocal first
        if first is None or k < first[0]:
            first = (k, what)

    below = -pts[:, :, :, 1].min(axis=2)  # (samples, blocks)
    for i, b in enumerate(blocks):
        deep = np.nonzero(below[:, i] > MODEL_DEPTH_FRACTION * smallest[i])[0]
        if deep.size:
            found(int(deep[0]), f"block `{b['name']}` lies {below[deep[0], i]:.3g} m below the ground")
    for a, ba in enumerate(blocks):
        for j, bj in enumerate(blocks):
            if a == j:
                continue
            dx = pts[:, a, :, 0] - states[:, j, 0][:, None]
            dz = pts[:, a, :, 1] - states[:, j, 1][:, None]
            c, s = np.cos(states[:, j, 2])[:, None], np.sin(states[:, j, 2])[:, None]
            lx, lz = c * dx + s * dz, -s * dx + c * dz
            depth = np.minimum(bj["width"] / 2 - np.abs(lx), bj["height"] / 2 - np.abs(lz)).max(axis=1)
            deep = np.nonzero(depth > MODEL_DEPTH_FRACTION * min(smallest[a], smallest[j]))[0]
            if deep.size:
                found(
                    int(deep[0]),
                    f"a corner of block `{ba['name']}` lies {depth[deep[0]]:.3g} m inside block `{bj['name']}`",
                )
    if first is None:
        return None
    return float(t[first[0]]), first[1]


def build_and_run(inp: dict[str, Any], s: dict[str, Any]) -> dict[str, Any]:
    import siconos.kernel as sk
    import siconos.numerics as sn

    spec = inp["scene"]
    blocks = spec["blocks"]
    n = len(blocks)
    supports: list[int | None] = inp["supports"]
    why = unsupported(spec, supports)
    if why is not None:
        raise WorkerError(5, why)
    friction: list[float] = inp["friction_below"]
    h = s["step"]
    g = spec["gravity"]
    mass = np.array([b["density"] * b["width"] * b["height"] for b in blocks])
    inertia = mass * np.array([(b["width"] ** 2 + b["height"] ** 2) / 12 for b in blocks])
    mdiag = np.repeat(mass, 3)
    mdiag[2::3] = inertia
    q0 = np.array([[b["x"], b["z"], b["phi"]] for b in inp["layout"]], dtype=float).ravel()
    v0 = np.array([[b["vx"], b["vz"], b["omega"]] for b in inp["layout"]], dtype=float).ravel()

    duration = float(spec["duration"])
    n_total, samples, last_step = time_grid(duration, spec["output_interval"], h)
    partial = last_step != h
    n_whole = n_total - 1 if partial else n_total
    ground = inp.get("ground")
    if ground is not None:
        if abs(ground["step"] - h) > 1e-15 * h:
            raise WorkerError(1, f"ground motion sampled every {ground['step']} s, step is {h} s")
        gvx = np.asarray(ground["vx"], dtype=float)
        gvz = np.asarray(ground["vz"], dtype=float)
        # The ground velocity at every step's end: whole steps, then the duration after a
        # shorter last step (src/engines/siconos.rs, `input`).
        if len(gvx) != n_total + 1 or len(gvz) != n_total + 1:
            raise WorkerError(
                1,
                f"ground motion at {len(gvx)} instants; the run's {n_total} steps need "
                f"{n_total + 1}",
            )
        lengths = np.full(n_total, h)
        lengths[-1] = last_step
        ax, az = np.diff(gvx) / lengths, np.diff(gvz) / lengths

    ds = sk.LagrangianLinearTIDS(q0, v0, np.diag(mdiag))
    fext = np.zeros(3 * n)
    fext[1::3] = -mass * g
    ds.setFExtPtr(fext)
    fext_live = ds.fExt()

    class Relation(sk.LagrangianScleronomousR):  # type: ignore[misc]
        def __init__(self, c: Contact) -> None:
            sk.LagrangianScleronomousR.__init__(self)
            self.c = c
            self.jac = sk.SimpleMatrix(2, 3 * n)
            self.setJachqPtr(self.jac)
            self.view = self.jachq()
            self.view[:, :] = 0.0

        def computeh(self, q: Any, z: Any, y: Any) -> None:
            gap, t = self.c.evaluate(q, None)
            y[0], y[1] = gap, t

        def computeJachq(self, q: Any, z: Any) -> None:
            self.c.evaluate(q, self.view)

        def computeDotJachq(self, q: Any, z: Any, qdot: Any) -> None:
            pass

        def C(self) -> Any:
            return self.jac

    nsds = sk.NonSmoothDynamicalSystem(0.0, n_total * h)
    nsds.insertDynamicalSystem(ds)
    keep: list[Any] = []
    for c in contacts(spec, supports, friction):
        law = sk.NewtonImpactFrictionNSL(s["restitution"], 0.0, c.mu, 2)
        rel = Relation(c)
        inter = sk.Interaction(law, rel)
        nsds.link(inter, ds)
        keep += [law, rel, inter]

    solver = getattr(sn, f"SICONOS_FRICTION_2D_{s['solver']}")
    osnspb = sk.FrictionContact(2, solver)
    opts = osnspb.numericsSolverOptions()
    opts.iparam[sn.SICONOS_IPARAM_MAX_ITER] = s["iterations"]
    opts.dparam[sn.SICONOS_DPARAM_TOL] = s["tolerance"]
    td = sk.TimeDiscretisation(0.0, h)
    if s["scheme"] == "plain":
        osi = sk.MoreauJeanOSI(s["theta"])
        sim = sk.TimeStepping(nsds, td, osi, osnspb)
    else:
        osi = sk.MoreauJeanDirectProjectionOSI(s["theta"])
        pos = sk.MLCPProjectOnConstraints(sn.SICONOS_MLCP_ENUM, 1.0)
        sim = sk.TimeSteppingDirectProjection(nsds, td, osi, osnspb, pos)
    keep += [osi, osnspb, td, sim]

    states = np.empty((len(samples), n, 6))
    k = 0
    sample_at = set(samples)

    def record() -> None:
        nonlocal k
        states[k, :, :3] = np.array(ds.q()).reshape(n, 3)
        states[k, :, 3:] = np.array(ds.velocity()).reshape(n, 3)
        k += 1

    def time_at(k: int) -> float:
        return duration if partial and k == n_total else k * h

    record()
    for step in range(n_total):
        if ground is not None:
            fext_live[0::3] = -mass * ax[step]
            fext_live[1::3] = -mass * (g + az[step])
        if partial and step == n_whole:
            # The shorter last step: an event at the duration, between the time
            # discretisation's instants n_whole * h and (n_whole + 1) * h, ends it there.
            sim.eventsManager().insertEvent(sk.TD_EVENT, duration)
            if sim.nextTime() != duration:
                raise WorkerError(
                    2,
                    f"siconos.step: the last step, {last_step:.6g} s to the duration "
                    f"({duration!r} s), is too close to a whole step for Siconos' events to "
                    f"tell apart: make the duration a whole number of steps (got {h!r})",
                )
        sim.computeOneStep()
        sim.nextStep()
        if step + 1 in sample_at:
            record()
            if not np.isfinite(states[k - 1]).all():
                raise WorkerError(
                    4, f"siconos: the state became NaN or infinite before t = {time_at(step + 1):.6g} s"
                )
    return {
        "t": np.array([time_at(j) for j in samples]),
        "states": states,
        "steps": n_total,
    }


def run(input_path: str, out: str, source: str | None) -> dict[str, Any]:
    try:
        with open(input_path) as f:
            inp = json.load(f)
    except (OSError, json.JSONDecodeError) as e:
        raise WorkerError(2, f"{input_path}: cannot read the input: {e}") from None
    spec = inp["scene"]
    s = read_settings(spec.get("siconos"))
    try:
        import siconos.kernel  # noqa: F401
    except ImportError as e:
        raise WorkerError(
            3,
            f"cannot import siconos ({e}) with {sys.executable}: run `make siconos` "
            "(Debian's python3-siconos in a venv of /usr/bin/python3), or set "
            "ROCKBENCH_SICONOS_PYTHON",
        ) from None
    version = siconos_version()
    # Siconos prints to stdout (block copies, solver warnings): keep it off the worker's stdout.
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    start = time.perf_counter()
    try:
        res = build_and_run(inp, s)
    finally:
        os.dup2(saved, 1)
        os.close(devnull)
        os.close(saved)
    wall = time.perf_counter() - start
    left = left_model(res["t"], res["states"], spec["blocks"])
    names = [b["name"] for b in spec["blocks"]]
    os.makedirs(out, exist_ok=True)
    header = ["t"] + [f"{nm}_{f}" for nm in names for f in FIELDS]
    t = res["t"]
    data = np.column_stack([t, res["states"].reshape(len(t), -1)])
    np.savetxt(
        os.path.join(out, "trajectory.csv"),
        data,
        delimiter=",",
        header=",".join(header),
        comments="",
        fmt="%.17g",
    )
    settings = dict(s)
    settings["model"] = (
        "one LagrangianLinearTIDS (x, z, phi per block), corner-face two-row relations, "
        "NewtonImpactFrictionNSL with the scene's interface friction, FrictionContact(2)"
    )
    settings["excitation"] = (
        "inertial forces, exact mean ground acceleration over each step"
        if inp.get("ground") is not None
        else "none"
    )
    notes: list[str] = []
    if (spec.get("excitation") or {}).get("applied_as") == "moving-ground":
        notes.append(
            "excitation.applied_as = moving-ground was applied as inertial forces on every "
            "block (the same motion relative to the ground)"
        )
    if left is not None:
        notes.append(
            f"the run leaves the model at t = {left[0]:.6g} s: {left[1]} (the model's contacts "
            "are each block's base corners on the face below, and none where an overturned "
            "block lands): the trajectory past it is no physical motion, and the events end there"
        )
    summary = {
        "engine": "siconos",
        "model_valid_until": None if left is None else left[0],
        "engine_version": version,
        "settings": settings,
        "steps": res["steps"],
        "wall_time_s": wall,
        "samples": len(t),
        "notes": notes,
    }
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
        f.write("\n")
    return summary


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="siconos_worker.py", description="Siconos worker")
    ap.add_argument("--input", required=True, help="input JSON written by the Rust harness")
    ap.add_argument("--out", required=True, help="output directory")
    ap.add_argument("--source", help="scene file named in error messages")
    a = ap.parse_args(argv)
    try:
        run(a.input, a.out, a.source)
    except WorkerError as e:
        msg = str(e) if e.code != 2 or not a.source else f"{a.source}: {e}"
        print(msg.replace("\n", " "), file=sys.stderr)
        return e.code
    except Exception as e:  # noqa: BLE001 - any engine exception is a failed run
        tb = traceback.extract_tb(e.__traceback__)
        where = f" ({tb[-1].filename}:{tb[-1].lineno})" if tb else ""
        print(f"siconos: {type(e).__name__}: {e}{where}".replace("\n", " "), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
