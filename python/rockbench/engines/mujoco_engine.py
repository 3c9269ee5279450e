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

Settings (the ``[mujoco]`` table; defaults measured against Housner's solution, see
ENGINES.md): ``timestep`` 1e-4 s; ``solref`` [0.0003, 1] (contact time constant, s, 3 x timestep,
and damping ratio; MuJoCo raises any time constant below 2 x timestep to 2 x timestep);
``solimp`` [0.99, 0.999, 0.0001]; ``cone`` elliptic; ``integrator`` implicitfast; ``solver``
Newton with ``iterations`` 100 and ``tolerance`` 1e-8; ``impratio`` 1; ``depth`` 1 m;
``excitation_interval`` 1e-3 s; ``timeout`` 600 s (harness).
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
    excitation_notes,
    mean_ground_acceleration,
    non_negative,
    numbers,
    one_of,
    positive,
    positive_int,
    read_settings,
    time_grid,
)

SETTINGS: dict[str, Setting] = {
    "timestep": Setting(1e-4, positive, "Integration step, s."),
    "solref": Setting(
        [0.0003, 1.0],
        numbers(2),
        "Contact reference: time constant (s) and damping ratio of every contact pair.",
    ),
    "solimp": Setting(
        [0.99, 0.999, 0.0001],
        numbers(3, 5),
        "Contact impedance: dmin, dmax, width (m) [, midpoint, power] of every contact pair.",
    ),
    "cone": Setting("elliptic", one_of("elliptic", "pyramidal"), "Friction cone."),
    "integrator": Setting(
        "implicitfast", one_of("implicitfast", "Euler", "implicit", "RK4"), "Integrator."
    ),
    "solver": Setting("Newton", one_of("Newton", "CG", "PGS"), "Constraint solver."),
    "iterations": Setting(100, positive_int, "Largest number of solver iterations per step."),
    "tolerance": Setting(1e-8, non_negative, "Solver tolerance."),
    "impratio": Setting(1.0, positive, "Ratio of frictional to normal impedance."),
    "depth": Setting(1.0, positive, "Out-of-plane size of the blocks, m."),
    "excitation_interval": Setting(
        1e-3,
        positive,
        "Interval between updates of the ground acceleration (its exact mean over the "
        "interval), s; rounded to whole steps.",
    ),
    **HARNESS_SETTINGS,
}


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
    mujoco = import_mujoco()
    model = mujoco.MjModel.from_xml_string(build_xml(scene, spec, s))
    data = mujoco.MjData(model)
    n = len(spec["blocks"])
    layout = scene.layout()
    for i, b in enumerate(layout):
        data.qpos[3 * i : 3 * i + 3] = (b["x"], b["z"], b["phi"])
        data.qvel[3 * i : 3 * i + 3] = (b["vx"], b["vz"], b["omega"])
    mujoco.mj_forward(model, data)

    h = s["timestep"]
    excited = "excitation" in spec
    grid = time_grid(
        spec["duration"],
        spec["output_interval"],
        h,
        s["excitation_interval"] if excited else None,
        "mujoco.timestep",
    )
    bounds = np.array(grid.boundaries)
    if excited:
        ax, az = mean_ground_acceleration(scene, bounds * h)
    g = spec["gravity"]
    sample_at = set(grid.sample_steps)
    states = np.empty((len(grid.sample_steps) + 1, n, 6))
    times: list[float] = []
    monitor = EarlyStop(early_stop) if early_stop is not None else None
    stop = "end"
    body_ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"b{i}") for i in range(n)]
    out_of_plane = 0.0
    k = 0
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
        mujoco.mj_step(model, data, nstep=int(bounds[c + 1] - bounds[c]))
        for w in (bad, mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL):
            if data.warning[w].number > 0:
                raise FloatingPointError(
                    f"MuJoCo reported an unstable simulation ({mujoco.mjtWarning(w).name}) "
                    f"before t = {bounds[c + 1] * h:.6g} s"
                )
        t = float(bounds[c + 1]) * h
        hit = None
        if monitor is not None:
            now = np.column_stack([data.qpos.reshape(n, 3), data.qvel.reshape(n, 3)])
            hit = monitor.check(t, now)
        if int(bounds[c + 1]) in sample_at or hit is not None:
            record(t)
        if hit is not None:
            stop = hit
            break
    steps = round(times[-1] / h)

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
