"""rockbench: rigid-block rocking dynamics and a cross-validation harness.

The Rust core is the private extension ``rockbench._native``; this package re-exports its
public names. ``rockbench.engines`` holds the MuJoCo and PyBullet engines, run by the Rust
harness as worker processes (``python -m rockbench.worker``).
"""

from rockbench._native import (
    Run,
    Scene,
    __version__,
    engine_names,
    fragility_run,
    fragility_run_specs,
    fragility_study,
    load_scene,
    run,
)
from rockbench.compare import compare

__all__ = [
    "Run",
    "Scene",
    "__version__",
    "compare",
    "engine_names",
    "fragility_run",
    "fragility_run_specs",
    "fragility_study",
    "load_scene",
    "run",
]
