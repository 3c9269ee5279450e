"""rockbench: rigid-block rocking dynamics and a cross-validation harness.

The Rust core is the private extension ``rockbench._native``; this package re-exports its
public names, and adds ``compare`` (a DataFrame of metrics), ``fragility`` and ``run_many``
(locally or on a Dask cluster: ``rockbench.study``, ``python -m rockbench.study``) with their
results as pandas DataFrames (``rockbench.results``). ``rockbench.engines`` holds the MuJoCo and PyBullet engines, run by the Rust
harness as worker processes (``python -m rockbench.worker``).
"""

from rockbench._native import (
    Run,
    Scene,
    __version__,
    engine_names,
    fragility_is_python_worker,
    fragility_run,
    fragility_run_specs,
    fragility_study,
    load_scene,
    run,
)
from rockbench.compare import compare
from rockbench.results import Comparison, FragilityResult, trajectory
from rockbench.studies import fragility, run_many

__all__ = [
    "Comparison",
    "FragilityResult",
    "Run",
    "Scene",
    "__version__",
    "compare",
    "engine_names",
    "fragility",
    "fragility_is_python_worker",
    "fragility_run",
    "fragility_run_specs",
    "fragility_study",
    "load_scene",
    "run",
    "run_many",
    "trajectory",
]
