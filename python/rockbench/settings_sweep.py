"""The measurement behind the MuJoCo and PyBullet defaults: each engine on Housner's two
free-rocking blocks (slender and square, released from 0.15 rad) with its default settings and
with one setting changed at a time, against the Housner engine.

    python -m rockbench.settings_sweep [--out out/settings-sweep.md]   (or `make settings-sweep`)

Columns: first impact minus Housner's (ms), relative error of the amplitude after the first
impact (%), RMS of the rotation difference over the whole run (rad), wall time of the run (s).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import rockbench

SCENES = ("housner-slender", "housner-square")

VARIANTS: dict[str, list[list[str]]] = {
    "mujoco": [
        [],
        ["mujoco.solref=[0.0002, 1.0]"],
        ["mujoco.solref=[0.0005, 1.0]"],
        ["mujoco.solref=[0.02, 1.0]"],
        ["mujoco.solref=[0.0003, 0.5]"],
        ["mujoco.cone=\"pyramidal\""],
        ["mujoco.timestep=5e-4", "mujoco.solref=[0.0015, 1.0]"],
    ],
    "pybullet": [
        [],
        ["pybullet.num_sub_steps=1"],
        ["pybullet.num_sub_steps=5"],
        ["pybullet.num_solver_iterations=10"],
        ["pybullet.fixed_time_step=2e-4", "pybullet.num_sub_steps=1"],
    ],
}


def block(run: rockbench.Run) -> dict[str, Any]:
    b: dict[str, Any] = run.summary["blocks"][0]
    return b


def row(scene: str, ref: rockbench.Run, engine: str, overrides: list[str]) -> str:
    start = time.perf_counter()
    try:
        got = rockbench.run(scene, engine=engine, overrides=overrides)
    except RuntimeError as e:
        return f"| {engine} | {' '.join(overrides) or 'defaults'} | failed: {e} | | | |"
    wall = time.perf_counter() - start
    r, g = block(ref), block(got)
    d_imp = 1e3 * (g["impacts"][0] - r["impacts"][0]) if g["impacts"] else float("nan")
    a_ref = r["peaks"][1]["amplitude"]
    a_got = g["peaks"][1]["amplitude"] if len(g["peaks"]) > 1 else float("nan")
    phi_ref = ref.blocks[r["name"]]["phi"]
    phi = np.interp(ref.t, got.t, got.blocks[r["name"]]["phi"])
    rms = float(np.sqrt(np.mean((phi - phi_ref) ** 2)))
    return (
        f"| {engine} | {' '.join(overrides) or 'defaults'} | {d_imp:+.2f} | "
        f"{100 * (a_got / a_ref - 1):+.2f} | {rms:.1e} | {wall:.1f} |"
    )


def references(scenes: str) -> dict[str, tuple[str, rockbench.Run]]:
    """Each scene of :data:`SCENES` in the folder `scenes` (its path) and its Housner run,
    before any other run; a ValueError naming ``--scenes`` and the file says what is wrong
    (no such folder, a scene missing or not a scene, no impact and second peak to measure)."""
    if not Path(scenes).is_dir():
        what = "not a directory" if Path(scenes).exists() else "no such directory"
        raise ValueError(f"--scenes {scenes}: {what}")
    refs = {}
    for name in SCENES:
        scene = str(Path(scenes) / f"{name}.toml")
        if not Path(scene).is_file():
            raise ValueError(
                f"--scenes {scenes}: no {name}.toml (the sweep needs "
                f"{' and '.join(n + '.toml' for n in SCENES)})"
            )
        try:
            ref = rockbench.run(scene, engine="housner")
        except (ValueError, RuntimeError) as e:
            why = str(e) if str(e).startswith(scene) else f"{scene}: {e}"
            raise ValueError(f"--scenes: {why}") from None
        if len(ref.summary["blocks"]) != 1 or not block(ref)["impacts"] or len(block(ref)["peaks"]) < 2:
            raise ValueError(
                f"--scenes: {scene}: not a free-rocking block (one block whose Housner run "
                "has an impact and a peak after it)"
            )
        refs[name] = (scene, ref)
    return refs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m rockbench.settings_sweep")
    ap.add_argument("--scenes", default="validation/scenes", help="directory of the scenes")
    ap.add_argument("--out", help="also write the table to this Markdown file")
    a = ap.parse_args(argv)
    try:
        refs = references(a.scenes)
    except ValueError as e:
        print(" ".join(str(e).split()), file=sys.stderr)
        return 2
    lines = []
    for name, (scene, ref) in refs.items():
        lines += [
            f"\n### {name}\n",
            "| engine | settings | first impact - Housner (ms) | amplitude after impact 1 (%) "
            "| RMS phi error (rad) | wall (s) |",
            "|---|---|---|---|---|---|",
        ]
        for engine, variants in VARIANTS.items():
            for ov in variants:
                lines.append(row(scene, ref, engine, ov))
                print(lines[-1], file=sys.stderr)
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        Path(a.out).parent.mkdir(parents=True, exist_ok=True)
        Path(a.out).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
