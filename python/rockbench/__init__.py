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
    __git_commit__,
    __source_hash__,
    __version__,
    engine_names,
    fragility_is_python_worker,
    fragility_run,
    fragility_run_specs,
    fragility_study,
    load_scene,
    run,
)
# The pandas-backed names are imported on first use (PEP 562), so the engine workers
# (`python -m rockbench.worker`, one process per run) do not pay for pandas.
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rockbench.compare import compare
    from rockbench.results import Comparison, FragilityResult, trajectory
    from rockbench.studies import fragility, run_many

_LAZY = {
    "compare": "rockbench.compare",
    "Comparison": "rockbench.results",
    "FragilityResult": "rockbench.results",
    "trajectory": "rockbench.results",
    "fragility": "rockbench.studies",
    "run_many": "rockbench.studies",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'rockbench' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)


__all__ = [
    "Comparison",
    "FragilityResult",
    "Run",
    "Scene",
    "__git_commit__",
    "__source_hash__",
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
