"""The measurement behind the Siconos engine's defaults (docs/engines-siconos.md).

    python -m rockbench.siconos_sweep [--bin target/release/rockbench] [--out out/siconos-sweep.md]

Runs ``rockbench compare --engines siconos --reference housner`` on the slender and square
Housner blocks for each scheme, step and theta below and tabulates the first impact's error,
the first amplitude's error, the RMS rotation error over the run and the wall time. Siconos
runs in its own interpreter (``make siconos``), so this only drives the ``rockbench`` binary.
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile

SCENES = ("housner-slender", "housner-square")
VARIANTS: list[dict[str, object]] = [
    {"scheme": scheme, "step": step, "theta": 0.5}
    for scheme in ("plain", "projection")
    for step in (1e-3, 5e-4, 2e-4, 1e-4, 5e-5)
]
VARIANTS += [
    {"scheme": "projection", "step": 1e-4, "theta": 1.0},
    {"scheme": "projection", "step": 1e-4, "theta": 0.5, "restitution": 0.1},
]


def measure(binary: str, scene: str, v: dict[str, object]) -> dict[str, float]:
    with tempfile.TemporaryDirectory() as out:
        cmd = [
            binary,
            "compare",
            f"validation/scenes/{scene}.toml",
            "--engines",
            "siconos",
            "--reference",
            "housner",
            "--quiet",
            "--out",
            out,
        ]
        for k, x in v.items():
            cmd += ["--set", f"siconos.{k}={x!r}" if isinstance(x, str) else f"siconos.{k}={x}"]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        with open(os.path.join(out, "metrics.csv")) as f:
            rows = {
                r["metric"]: r
                for r in csv.DictReader(f)
                if r["engine"] == "siconos" and r["block"] in ("block", "(run)")
            }

    def err(name: str) -> tuple[float, float]:
        r = rows[name]
        return float(r["value"]), float(r["reference"])

    t1, t1r = err("impact_time_1")
    a1, a1r = err("peak_amplitude_1")
    return {
        "impact_ms": (t1 - t1r) * 1e3,
        "a1_pct": (a1 / a1r - 1) * 100,
        "rms": float(rows["rotation_rms_error"]["value"]),
        "wall": float(rows["wall_time"]["value"]),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0] if __doc__ else None)
    ap.add_argument("--bin", default="target/release/rockbench")
    ap.add_argument("--out", default="out/siconos-sweep.md")
    a = ap.parse_args(argv)
    lines = [
        "| scene | scheme | step (s) | theta | e | first impact (ms) | A1 (%) | RMS rotation (rad) | wall (s) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for scene in SCENES:
        for v in VARIANTS:
            m = measure(a.bin, scene, v)
            line = (
                f"| {scene} | {v['scheme']} | {v['step']:g} | {v['theta']} | "
                f"{v.get('restitution', 0)} | {m['impact_ms']:+.3f} | {m['a1_pct']:+.3f} | "
                f"{m['rms']:.2e} | {m['wall']:.1f} |"
            )
            print(line, file=sys.stderr)
            lines.append(line)
    os.makedirs(os.path.dirname(a.out) or ".", exist_ok=True)
    with open(a.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
