"""The MuJoCo engine: a rockbench scene as a planar MuJoCo model.

Each block is a body with three joints at its centroid, slide-x, slide-z and hinge about -y
(so the hinge angle is the counter-clockwise rotation ``phi``), and a box geom of the block's
width and height and ``depth`` out of plane (mass per metre of depth = density * B * H for
depth 1). The ground is a plane at z = 0. Every pair that can touch (ground-block and
block-block) is an explicit contact pair with the scene's interface friction, condim 3, and the
``solref`` / ``solimp`` below; restitution comes only from the contact's damping (ratio 1: none),
joints have no damping. Ground motion is applied as inertial forces on every block through the
gravity vector, updated every ``excitation_interval`` with the exact mean ground acceleration
over the interval. The model is stepped with ``mj_step(m, d, nstep)`` between updates.

A duration that is not a whole number of ``timestep`` ends with one shorter step (``timestep``
set to the rest for that step), so the last sample is at the duration as in the native engine.

Settings (the ``[mujoco]`` table; defaults measured against Housner's solution, see
ENGINES.md): ``timestep`` 1e-4 s; ``solref`` [0.0003, 1] (contact time constant, s, 3 x timestep,
and damping ratio; a time constant below 2 x timestep, which MuJoCo would raise to 2 x timestep,
is refused, and the default becomes 2 x timestep when that is longer);
``solimp`` [0.99, 0.999, 0.0001]; ``cone`` elliptic; ``integrator`` implicitfast; ``solver``
Newton with ``iterations`` 100 and ``tolerance`` 1e-8; ``impratio`` 1; ``depth`` 1 m;
``excitation_interval`` 1e-3 s; ``timeout`` 600 s (harness). The bounds of each setting are in
``SETTINGS``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rockbench.engines.common import (
    HARNESS_SETTINGS,
    EarlyStop,
    EngineResult,
    Setting,
    SettingsError,
    block_dimensions,
    check_depth,
    check_step_resolves,
    excitation_notes,
    mean_ground_acceleration,
    numbers,
    one_of,
    positive,
    positive_int,
    read_settings,
    residual_tolerance,
    time_grid,
)

# MuJoCo's range of a constraint impedance (mujoco.mjMINIMP, mujoco.mjMAXIMP): getsolparam
# (engine_core_constraint.c) clamps solimp's dmin, dmax and midpoint into it.
MIN_IMPEDANCE = 0.0001
MAX_IMPEDANCE = 0.9999
# The depth of the blocks' boxes relative to the scene's blocks (see SETTINGS["depth"]).
DEPTH_MIN_FRACTION = 0.01
DEPTH_MAX_MULTIPLE = 100.0
# Default contact time constant, s (the default solref's first number).
DEFAULT_TIMECONST = 0.0003


def solref(name: str, v: Any) -> list[float]:
    """Time constant (s) > 0 and damping ratio > 0: MuJoCo's standard format (negative numbers
    are its direct stiffness-damping format, not used here). The bound against the timestep is
    checked in ``check_settings``."""
    tc, ratio = numbers(2)(name, v)
    if tc <= 0 or ratio <= 0:
        raise SettingsError(
            f"{name}: time constant and damping ratio must both be > 0 (got {v!r})"
        )
    return [tc, ratio]


def solimp(name: str, v: Any) -> list[float]:
    """dmin, dmax, width [, midpoint, power] within the ranges MuJoCo uses them in (it clamps
    dmin, dmax and midpoint into [mjMINIMP, mjMAXIMP] and power to >= 1; width <= 0 is a
    constant impedance)."""
    out = numbers(3, 5)(name, v)
    imp = f"[{MIN_IMPEDANCE}, {MAX_IMPEDANCE}] (MuJoCo's mjMINIMP, mjMAXIMP)"
    for i, what in ((0, "dmin"), (1, "dmax")) + (((3, "midpoint"),) if len(out) == 5 else ()):
        if not MIN_IMPEDANCE <= out[i] <= MAX_IMPEDANCE:
            raise SettingsError(f"{name}: {what} must be in {imp} (got {v!r})")
    if out[2] <= 0:
        raise SettingsError(f"{name}: width must be > 0 m (got {v!r})")
    if len(out) == 5 and out[4] < 1:
        raise SettingsError(f"{name}: power must be >= 1 (got {v!r})")
    return out


SETTINGS: dict[str, Setting] = {
    "timestep": Setting(1e-4, positive, "Integration step, s."),
    "solref": Setting(
        [DEFAULT_TIMECONST, 1.0],
        solref,
        "Contact reference: time constant (s) and damping ratio of every contact pair, both "
        "> 0; the time constant at least 2 x timestep (MuJoCo would raise a shorter one to "
        "that, its integrator safety rule). Default [0.0003, 1], its time constant 2 x "
        "timestep when that is longer.",
    ),
    "solimp": Setting(
        [0.99, 0.999, 0.0001],
        solimp,
        "Contact impedance: dmin, dmax, width (m) [, midpoint, power] of every contact pair; "
        "dmin, dmax and midpoint in [0.0001, 0.9999] (MuJoCo clamps them into it), width > 0, "
        "power >= 1.",
    ),
    "cone": Setting("elliptic", one_of("elliptic", "pyramidal"), "Friction cone."),
    "integrator": Setting(
        "implicitfast", one_of("implicitfast", "Euler", "implicit", "RK4"), "Integrator."
    ),
    "solver": Setting("Newton", one_of("Newton", "CG", "PGS"), "Constraint solver."),
    "iterations": Setting(
        100, positive_int, "Largest number of solver iterations per step, 1 to 2^31 - 1 (a C int)."
    ),
    "tolerance": Setting(
        1e-8,
        residual_tolerance(allow_zero=True),
        "Solver tolerance: MuJoCo's early-termination threshold on the scaled cost improvement "
        "and gradient, a relative residual, in [0, 1) (0: no early termination; 1 or more "
        "stops at the first iterate).",
    ),
    "impratio": Setting(1.0, positive, "Ratio of frictional to normal impedance."),
    "depth": Setting(
        1.0,
        positive,
        "Out-of-plane size of the blocks, m: from 0.01 x the smallest block width or height "
        "to 100 x the largest. The planar motion does not depend on it (mass and inertia per "
        "metre of depth; measured identical to round-off from 1e-12 to 1e6 x the block on "
        "housner-square); the window keeps every block a prism of the scene's proportions, "
        "far from where MuJoCo's geometry loses precision (4e-6 rad off at 1e9 x) or the mass "
        "falls below mjMINVAL (a model error). A given depth outside it is refused; the default "
        "1 m is brought to the nearer bound (recorded in the run's settings).",
    ),
    "excitation_interval": Setting(
        1e-3,
        positive,
        "Interval between updates of the ground acceleration (its exact mean over the "
        "interval), s; rounded to whole steps.",
    ),
    **HARNESS_SETTINGS,
}


def check_settings(spec: dict[str, Any], s: dict[str, Any]) -> None:
    """The checks of ``s`` (the settings read) that need the scene or another setting; fills
    the default ``solref`` for the timestep."""
    given = spec.get("mujoco") or {}
    h = s["timestep"]
    if "solref" not in given:
        s["solref"] = [max(DEFAULT_TIMECONST, 2 * h), s["solref"][1]]
    elif s["solref"][0] < 2 * h:
        raise SettingsError(
            f"mujoco.solref: the time constant must be at least 2 x mujoco.timestep "
            f"({2 * h:.6g} s; MuJoCo would raise it to that) (got {given['solref']!r})"
        )
    small, large = block_dimensions(spec)
    check_depth(
        s,
        "mujoco.depth",
        "depth" in given,
        DEPTH_MIN_FRACTION * small,
        f"{DEPTH_MIN_FRACTION:g} x the smallest block dimension",
        DEPTH_MAX_MULTIPLE * large,
        f"{DEPTH_MAX_MULTIPLE:g} x the largest",
    )


def import_mujoco() -> Any:
    import mujoco

    return mujoco


def build_xml(scene: Any, spec: dict[str, Any], s: dict[str, Any]) -> str:
    """The MJCF model of a scene (``spec`` is the scene dict, ``s`` the checked settings)."""
    blocks = spec["blocks"]
    solref = " ".join(repr(x) for x in s["solref"])
    solimp = " ".join(repr(x) for x in s["solimp"])
    depth = s["depth"]
    span = sum(b["width"] + b["height"] for b in blocks) * 10 + 10
    bodies = []
    for i, b in enumerate(blocks):
        bodies.append(
            f'<body name="b{i}">'
            f'<joint name="x{i}" type="slide" axis="1 0 0"/>'
            f'<joint name="z{i}" type="slide" axis="0 0 1"/>'
            f'<joint name="phi{i}" type="hinge" axis="0 -1 0"/>'
            f'<geom name="g{i}" type="box" size="{b["width"] / 2!r} {depth / 2!r} '
            f'{b["height"] / 2!r}" density="{b["density"]!r}" contype="0" conaffinity="0"/>'
            "</body>"
        )
    pairs = []
    for i in range(len(blocks)):
        lowers: list[int | None] = [None, *range(i)]
        for j in lowers:
            mu = scene.friction_between(j, i)
            other = "ground" if j is None else f"g{j}"
            pairs.append(
                f'<pair geom1="{other}" geom2="g{i}" condim="3" '
                f'friction="{mu!r} {mu!r} 0 0 0" solref="{solref}" solimp="{solimp}"/>'
            )
    return (
        '<mujoco model="rockbench">'
        f'<option timestep="{s["timestep"]!r}" gravity="0 0 {-spec["gravity"]!r}" '
        f'integrator="{s["integrator"]}" cone="{s["cone"]}" solver="{s["solver"]}" '
        f'iterations="{s["iterations"]}" tolerance="{s["tolerance"]!r}" '
        f'impratio="{s["impratio"]!r}"/>'
        '<worldbody><geom name="ground" type="plane" '
        f'size="{span!r} {span!r} 1" contype="0" conaffinity="0"/>'
        + "".join(bodies)
        + "</worldbody><contact>"
        + "".join(pairs)
        + "</contact></mujoco>"
    )


def run(scene: Any, spec: dict[str, Any], early_stop: dict[str, Any] | None = None) -> EngineResult:
    """Run a checked scene (``rockbench.Scene``) whose dict form is ``spec``; with an
    ``early_stop`` rule (``common.EarlyStop``) the run ends at its stop, checked after every
    excitation update."""
    s = read_settings("mujoco", spec.get("mujoco"), SETTINGS)
    h = s["timestep"]
    excited = "excitation" in spec
    grid = time_grid(
        spec["duration"],
        spec["output_interval"],
        h,
        s["excitation_interval"] if excited else None,
        "mujoco.timestep",
    )
    check_step_resolves(spec, h, "mujoco.timestep")
    check_settings(spec, s)
    mujoco = import_mujoco()
    model = mujoco.MjModel.from_xml_string(build_xml(scene, spec, s))
    data = mujoco.MjData(model)
    n = len(spec["blocks"])
    layout = scene.layout()
    for i, b in enumerate(layout):
        data.qpos[3 * i : 3 * i + 3] = (b["x"], b["z"], b["phi"])
        data.qvel[3 * i : 3 * i + 3] = (b["vx"], b["vz"], b["omega"])
    mujoco.mj_forward(model, data)

    bounds = np.array(grid.boundaries)
    if excited:
        ax, az = mean_ground_acceleration(scene, grid.times(bounds))
    g = spec["gravity"]
    sample_at = set(grid.sample_steps)
    states = np.empty((len(grid.sample_steps) + 1, n, 6))
    times: list[float] = []
    monitor = EarlyStop(early_stop) if early_stop is not None else None
    stop = "end"
    body_ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"b{i}") for i in range(n)]
    out_of_plane = 0.0
    k = 0
    steps = 0
    bad = mujoco.mjtWarning.mjWARN_BADQACC

    def record(t: float) -> None:
        nonlocal k, out_of_plane
        times.append(t)
        states[k, :, :3] = data.qpos.reshape(n, 3)
        states[k, :, 3:] = data.qvel.reshape(n, 3)
        # Angle between each block's own y axis and the world's y axis.
        for bid in body_ids:
            r = data.xmat[bid]
            out_of_plane = max(out_of_plane, math.atan2(math.hypot(r[1], r[7]), abs(r[4])))
        k += 1

    record(0.0)
    for c in range(len(bounds) - 1):
        if excited:
            model.opt.gravity[:] = (-ax[c], 0.0, -(g + az[c]))
        end = int(bounds[c + 1])
        whole = end - int(bounds[c])
        if grid.partial and end == grid.n_steps:
            # The shorter last step, ending at the duration.
            whole -= 1
        if whole > 0:
            mujoco.mj_step(model, data, nstep=whole)
        if whole < end - int(bounds[c]):
            model.opt.timestep = grid.last_step
            mujoco.mj_step(model, data)
            model.opt.timestep = h
        t = grid.time(end)
        for w in (bad, mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL):
            if data.warning[w].number > 0:
                raise FloatingPointError(
                    f"MuJoCo reported an unstable simulation ({mujoco.mjtWarning(w).name}) "
                    f"before t = {t:.6g} s"
                )
        steps = end
        hit = None
        if monitor is not None:
            now = np.column_stack([data.qpos.reshape(n, 3), data.qvel.reshape(n, 3)])
            hit = monitor.check(t, now)
        if end in sample_at or hit is not None:
            record(t)
        if hit is not None:
            stop = hit
            break

    settings = dict(s)
    settings["excitation"] = (
        "inertial forces (gravity vector), mean ground acceleration over each "
        f"{max(1, round(s['excitation_interval'] / h)) * h:.6g} s"
        if excited
        else "none"
    )
    settings["ground"] = "plane"
    settings["friction"] = "scene interface friction on explicit contact pairs, condim 3"
    settings["restitution"] = "none (contact damping ratio from solref)"
    extra: dict[str, Any] = {"max_out_of_plane_rad": out_of_plane}
    if monitor is not None:
        extra["early_stop"] = {"stop": stop, "t": times[-1]}
    return EngineResult(
        t=np.array(times),
        names=[b["name"] for b in spec["blocks"]],
        states=states[:k],
        settings=settings,
        engine_version=f"mujoco {mujoco.__version__}",
        steps=steps,
        notes=excitation_notes(spec),
        extra=extra,
    )


__all__ = ["SETTINGS", "SettingsError", "build_xml", "run"]
