"""The PyBullet engine: a rockbench scene as planar PyBullet multibodies on a box ground.

Each block is a multibody with a fixed massless base and three links at the block's centroid:
prismatic x and prismatic z (massless, no shape), then revolute about -y carrying the block's
box (so the joint angle is the counter-clockwise rotation ``phi``), motors disabled (velocity
control with force 0), joint, linear and angular damping 0. The motion is therefore exactly
planar. The ground is a static box whose top face is z = 0 (not GEOM_PLANE: on a plane the
contact points are added one at a time and blocks roll out of plane).

Bullet combines two bodies' friction coefficients by multiplying them and restitution likewise;
restitution is 0 on every body. ``lateral_friction`` null (default) reproduces the scene's
interface friction on every initial support: the ground gets ``ground_friction`` and each block
``mu / (friction of its support)``; a number sets every body's coefficient to it. Ground motion
is applied as inertial forces on every block through the gravity vector, updated at every
``stepSimulation`` call (each ``fixed_time_step``) with the exact mean ground acceleration over
it.

A duration that is not a whole number of ``fixed_time_step`` ends with one shorter
``stepSimulation`` call (``fixedTimeStep`` set to the rest for that call, with the same number of
sub-steps), so the last sample is at the duration as in the native engine.

Settings (the ``[pybullet]`` table; defaults measured against Housner's solution, see
ENGINES.md): ``fixed_time_step`` 1e-3 s with ``num_sub_steps`` 10 (internal step 1e-4 s);
``num_solver_iterations`` 50; ``lateral_friction`` null; ``ground_friction`` 1; ``erp``,
``contact_erp``, ``friction_erp`` 0.2, 0.2, 0.2 (Bullet's defaults, recorded);
``depth`` 1 m; ``ground_half_size`` 50 m; ``timeout`` 600 s (harness). The bounds of each
setting are in ``SETTINGS``.
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib.metadata
import math
import os
import sys
from typing import Any, Iterator

import numpy as np

from rockbench.engines.common import (
    HARNESS_SETTINGS,
    MAX_STEPS,
    EarlyStop,
    EngineFailure,
    EngineResult,
    Setting,
    SettingsError,
    TimeGrid,
    block_dimensions,
    check_depth,
    check_step_resolves,
    excitation_notes,
    farthest_corner,
    fraction,
    given_or_default,
    mean_ground_acceleration,
    non_negative,
    optional,
    positive,
    positive_int,
    read_settings,
    time_grid,
)

# The depth of the blocks' boxes relative to the scene's blocks (see SETTINGS["depth"]).
DEPTH_MIN_FRACTION = 0.01
DEPTH_MAX_MULTIPLE = 50.0

SETTINGS: dict[str, Setting] = {
    "fixed_time_step": Setting(1e-3, positive, "Time advanced by one stepSimulation call, s."),
    "num_sub_steps": Setting(
        10,
        positive_int,
        "Internal sub-steps per call (internal step = fixed_time_step / this), 1 to 2^31 - 1 "
        "(a C int), and at most 1e9 internal steps in the run (calls x this, the harness's "
        "limit on steps).",
    ),
    "num_solver_iterations": Setting(
        50, positive_int, "Constraint solver iterations, 1 to 2^31 - 1 (a C int)."
    ),
    "lateral_friction": Setting(
        None,
        optional(non_negative),
        "Friction coefficient of every body; null: the scene's interface friction on every "
        "initial support (Bullet multiplies the two bodies' coefficients).",
    ),
    "ground_friction": Setting(
        1.0, positive, "The ground's own coefficient when lateral_friction is null."
    ),
    "erp": Setting(0.2, fraction, "Error reduction parameter of joints, in [0, 1]."),
    "contact_erp": Setting(0.2, fraction, "Error reduction parameter of contacts, in [0, 1]."),
    "friction_erp": Setting(0.2, fraction, "Error reduction parameter of friction, in [0, 1]."),
    "depth": Setting(
        1.0,
        positive,
        "Out-of-plane size of the blocks, m: from 0.01 x to 50 x the smallest block width or "
        "height. The planar motion does not depend on it (mass and inertia per metre of depth: "
        "identical to round-off within the window); Bullet's box contacts need a box of "
        "moderate aspect ratio: the landing corner of a rocking block went through the ground "
        "undetected from a depth of 90-120 x its width (measured on 0.02, 0.125 and 1.25 m "
        "wide blocks; the upper bound keeps a factor of about 2 from it), and blocks fell "
        "through the ground below a depth of 1e-5 to 2e-5 m (1e-5 to 1e-4 x their width; the "
        "lower bound keeps a factor of more than 100). A given depth outside them is refused; "
        "the default 1 m is brought to the nearer bound (recorded in the run's settings).",
    ),
    "ground_half_size": Setting(
        50.0,
        positive,
        "Half length of the ground box, m: at least the farthest block corner from x = 0 at "
        "the start plus the largest block dimension (the reach of a block that tips over about "
        "that corner), so every block starts, rocks and lands on the ground. A given size below "
        "it is refused; the default 50 m is raised to it (recorded in the run's settings).",
    ),
    **HARNESS_SETTINGS,
}


def check_settings(spec: dict[str, Any], layout: list[dict[str, Any]], s: dict[str, Any]) -> None:
    """The checks of ``s`` (the settings read) that need the scene."""
    given = spec.get("pybullet") or {}
    small, large = block_dimensions(spec)
    check_depth(
        s,
        "pybullet.depth",
        "depth" in given,
        DEPTH_MIN_FRACTION * small,
        f"{DEPTH_MIN_FRACTION:g} x the smallest block dimension",
        DEPTH_MAX_MULTIPLE * small,
        f"{DEPTH_MAX_MULTIPLE:g} x it",
    )
    far = farthest_corner(spec, layout)
    need = far + large
    if "ground_half_size" not in given:
        s["ground_half_size"] = max(s["ground_half_size"], need)
    if s["ground_half_size"] < need:
        raise SettingsError(
            f"pybullet.ground_half_size: must be at least the farthest block corner from "
            f"x = 0 ({far:.6g} m) plus the largest block dimension ({large:.6g} m), "
            f"{need:.6g} m (got {s['ground_half_size']!r}"
            f"{given_or_default('ground_half_size' in given)})"
        )


@contextlib.contextmanager
def quiet_stdout() -> Iterator[None]:
    """PyBullet prints its build time on import; keep the worker's stdout clean."""
    sys.stdout.flush()
    fd = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            yield
            ctypes.CDLL(None).fflush(None)  # C stdio buffers its output
    finally:
        os.dup2(fd, 1)
        os.close(fd)


def import_pybullet() -> Any:
    with quiet_stdout():
        import pybullet

    return pybullet


def frictions(scene: Any, layout: list[dict[str, Any]], s: dict[str, Any]) -> tuple[float, list[float]]:
    """Ground and per-block coefficients such that every initial support's product is the
    scene's interface friction."""
    if s["lateral_friction"] is not None:
        mu = s["lateral_friction"]
        return mu, [mu] * len(layout)
    names = [b["name"] for b in layout]
    ground = s["ground_friction"]
    per: list[float] = []
    for i, b in enumerate(layout):
        below = None if b["support"] is None else names.index(b["support"])
        f_below = ground if below is None else per[below]
        mu = scene.friction_between(below, i)
        if f_below == 0.0:
            # Any coefficient makes a frictionless product with the block below; 1 leaves the
            # blocks above free to have theirs. A friction on it cannot be made (the harness
            # says so before the run: `pybullet_cannot_model` in src/engines/external.rs).
            if mu != 0.0:
                raise ValueError(
                    f"block `{b['name']}`: friction {mu} on `{b['support']}`, whose own "
                    "coefficient is 0, is no product of per-body coefficients"
                )
            per.append(1.0)
        else:
            per.append(mu / f_below)
    return ground, per


def run(scene: Any, spec: dict[str, Any], early_stop: dict[str, Any] | None = None) -> EngineResult:
    """Run a checked scene (``rockbench.Scene``) whose dict form is ``spec``; with an
    ``early_stop`` rule (``common.EarlyStop``) the run ends at its stop, checked after every
    ``stepSimulation`` call."""
    s = read_settings("pybullet", spec.get("pybullet"), SETTINGS)
    h = s["fixed_time_step"]
    excited = "excitation" in spec
    grid = time_grid(
        spec["duration"], spec["output_interval"], h, h if excited else None, "pybullet.fixed_time_step"
    )
    check_step_resolves(spec, h, "pybullet.fixed_time_step")
    internal = grid.n_steps * s["num_sub_steps"]
    if internal > MAX_STEPS:
        raise SettingsError(
            f"pybullet.num_sub_steps: {grid.n_steps} calls x {s['num_sub_steps']} sub-steps = "
            f"{internal:e} internal steps; at most {MAX_STEPS:e} are allowed "
            f"(got {s['num_sub_steps']!r})"
        )
    check_settings(spec, scene.layout(), s)
    p = import_pybullet()
    client = p.connect(p.DIRECT)
    try:
        return _run(p, client, scene, spec, s, grid, early_stop)
    finally:
        p.disconnect(physicsClientId=client)


def _run(
    p: Any,
    cid: int,
    scene: Any,
    spec: dict[str, Any],
    s: dict[str, Any],
    grid: TimeGrid,
    early_stop: dict[str, Any] | None,
) -> EngineResult:
    h = s["fixed_time_step"]
    g = spec["gravity"]
    p.setGravity(0, 0, -g, physicsClientId=cid)
    p.setPhysicsEngineParameter(
        fixedTimeStep=h,
        numSubSteps=s["num_sub_steps"],
        numSolverIterations=s["num_solver_iterations"],
        erp=s["erp"],
        contactERP=s["contact_erp"],
        frictionERP=s["friction_erp"],
        restitutionVelocityThreshold=0,
        physicsClientId=cid,
    )
    layout = scene.layout()
    n = len(layout)
    mu_ground, mu_blocks = frictions(scene, layout, s)
    depth = s["depth"]
    half = s["ground_half_size"]
    thick = 0.5
    gshape = p.createCollisionShape(
        p.GEOM_BOX, halfExtents=[half, depth, thick], physicsClientId=cid
    )
    ground = p.createMultiBody(
        baseMass=0,
        baseCollisionShapeIndex=gshape,
        basePosition=[0, 0, -thick],
        physicsClientId=cid,
    )
    p.changeDynamics(
        ground, -1, lateralFriction=mu_ground, restitution=0, rollingFriction=0,
        spinningFriction=0, physicsClientId=cid,
    )
    bodies = []
    for i, b in enumerate(spec["blocks"]):
        shape = p.createCollisionShape(
            p.GEOM_BOX,
            halfExtents=[b["width"] / 2, depth / 2, b["height"] / 2],
            physicsClientId=cid,
        )
        mass = b["density"] * b["width"] * b["height"] * depth
        zero = [0.0, 0.0, 0.0]
        ident = [0.0, 0.0, 0.0, 1.0]
        body = p.createMultiBody(
            baseMass=0,
            baseCollisionShapeIndex=-1,
            baseVisualShapeIndex=-1,
            basePosition=zero,
            linkMasses=[0.0, 0.0, mass],
            linkCollisionShapeIndices=[-1, -1, shape],
            linkVisualShapeIndices=[-1, -1, -1],
            linkPositions=[zero, zero, zero],
            linkOrientations=[ident, ident, ident],
            linkInertialFramePositions=[zero, zero, zero],
            linkInertialFrameOrientations=[ident, ident, ident],
            linkParentIndices=[0, 1, 2],
            linkJointTypes=[p.JOINT_PRISMATIC, p.JOINT_PRISMATIC, p.JOINT_REVOLUTE],
            linkJointAxis=[[1, 0, 0], [0, 0, 1], [0, -1, 0]],
            physicsClientId=cid,
        )
        p.changeDynamics(body, -1, linearDamping=0, angularDamping=0, physicsClientId=cid)
        for link in range(3):
            p.changeDynamics(
                body, link, lateralFriction=mu_blocks[i], restitution=0, rollingFriction=0,
                spinningFriction=0, linearDamping=0, angularDamping=0, jointDamping=0,
                physicsClientId=cid,
            )
        p.setJointMotorControlArray(
            body, [0, 1, 2], p.VELOCITY_CONTROL, targetVelocities=[0, 0, 0], forces=[0, 0, 0],
            physicsClientId=cid,
        )
        st = layout[i]
        for j, (q, v) in enumerate(
            [(st["x"], st["vx"]), (st["z"], st["vz"]), (st["phi"], st["omega"])]
        ):
            p.resetJointState(body, j, q, targetVelocity=v, physicsClientId=cid)
        bodies.append(body)

    excited = "excitation" in spec
    bounds = np.array(grid.boundaries)
    if excited:
        ax, az = mean_ground_acceleration(scene, grid.times(bounds))
    sample_at = set(grid.sample_steps)
    states = np.empty((len(grid.sample_steps) + 1, n, 6))
    times: list[float] = []
    monitor = EarlyStop(early_stop) if early_stop is not None else None
    stop = "end"
    now = np.empty((n, 6))
    out_of_plane = 0.0
    k = 0
    calls = 0

    def read() -> None:
        for i, body in enumerate(bodies):
            js = p.getJointStates(body, [0, 1, 2], physicsClientId=cid)
            now[i, :3] = [j[0] for j in js]
            now[i, 3:] = [j[1] for j in js]

    # Each block's half-diagonal: its centre that near the ground box's edge has a corner past it.
    reach = [0.5 * math.hypot(b["width"], b["height"]) for b in spec["blocks"]]

    def record(t: float) -> None:
        nonlocal k, out_of_plane
        for i, b in enumerate(spec["blocks"]):
            if abs(now[i, 0]) + reach[i] >= half:
                raise EngineFailure(
                    f"block `{b['name']}` reached the edge of PyBullet's ground box (x = "
                    f"{now[i, 0]:.3f} m, the box {half:.3f} m either side of x = 0, "
                    f"pybullet.ground_half_size) at t = {t:.6f} s: past it the block would fall "
                    "off a ground the scene does not have"
                )
        times.append(t)
        states[k] = now
        for body in bodies:
            orn = p.getLinkState(body, 2, physicsClientId=cid)[5]
            m = p.getMatrixFromQuaternion(orn)
            # Angle between the block's own y axis and the world's y axis.
            out_of_plane = max(out_of_plane, math.atan2(math.hypot(m[1], m[7]), abs(m[4])))
        k += 1

    read()
    record(0.0)
    for c in range(len(bounds) - 1):
        if excited:
            p.setGravity(-ax[c], 0, -(g + az[c]), physicsClientId=cid)
        end = int(bounds[c + 1])
        for step in range(int(bounds[c]) + 1, end + 1):
            if grid.partial and step == grid.n_steps:
                # The shorter last call, ending at the duration.
                p.setPhysicsEngineParameter(fixedTimeStep=grid.last_step, physicsClientId=cid)
                p.stepSimulation(physicsClientId=cid)
                p.setPhysicsEngineParameter(fixedTimeStep=h, physicsClientId=cid)
            else:
                p.stepSimulation(physicsClientId=cid)
        calls = end
        t = grid.time(end)
        sample = end in sample_at
        hit = None
        if monitor is not None or sample:
            read()
        if monitor is not None:
            hit = monitor.check(t, now)
        if sample or hit is not None:
            record(t)
        if hit is not None:
            stop = hit
            break

    params = p.getPhysicsEngineParameters(physicsClientId=cid)
    settings = dict(s)
    settings["lateral_friction_used"] = {"ground": mu_ground} | {
        b["name"]: mu_blocks[i] for i, b in enumerate(spec["blocks"])
    }
    settings["engine_parameters"] = {
        k: v
        for k, v in params.items()
        if isinstance(v, (int, float, str)) and not k.startswith("gravity")
    }
    settings["excitation"] = (
        f"inertial forces (gravity vector), mean ground acceleration over each {h:.6g} s"
        if excited
        else "none"
    )
    settings["ground"] = "box"
    settings["model"] = (
        "planar multibody per block: fixed massless base, prismatic x, prismatic z, revolute -y"
    )
    settings["restitution"] = 0.0
    settings["damping"] = 0.0
    extra: dict[str, Any] = {"max_out_of_plane_rad": out_of_plane}
    if monitor is not None:
        extra["early_stop"] = {"stop": stop, "t": times[-1]}
    return EngineResult(
        t=np.array(times),
        names=[b["name"] for b in spec["blocks"]],
        states=states[:k],
        settings=settings,
        engine_version=f"pybullet {importlib.metadata.version('pybullet')} (API {p.getAPIVersion()})",
        steps=calls * s["num_sub_steps"],
        notes=excitation_notes(spec),
        extra=extra,
    )


__all__ = ["SETTINGS", "SettingsError", "frictions", "run"]
