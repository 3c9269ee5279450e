"""Type stubs of the Rust extension ``rockbench._native`` (checked by ``mypy.stubtest``)."""

import os
from typing import Any, Sequence, final

import numpy as np
import numpy.typing as npt

__version__: str
#: outcomes.csv's columns before one column per limit state.
OUTCOME_COLUMNS: list[str]
#: The commit the extension was built from (`` (modified)`` when its build inputs differed).
__git_commit__: str
#: The hash of the extension's Rust sources (``src/``), as ``rockbench --version`` prints it.
__source_hash__: str
__all__ = [
    "__version__",
    "__git_commit__",
    "__source_hash__",
    "Scene",
    "Run",
    "load_scene",
    "run",
    "check_engine_names",
    "check_study_out",
    "OUTCOME_COLUMNS",
    "engine_names",
    "compare_rows",
    "fragility_study",
    "fragility_run_specs",
    "fragility_run",
    "fragility_cache_dir",
    "fragility_ida_jobs",
    "fragility_ida_batch",
    "fragility_run_batch",
    "fragility_store",
    "fragility_cache_has",
    "fragility_is_python_worker",
    "fragility_worker_scene",
    "fragility_worker_early_stop",
    "fragility_worker_outcome",
]

@final
class Scene:
    """A checked scene."""

    @property
    def name(self) -> str: ...
    @property
    def duration(self) -> float: ...
    @property
    def output_interval(self) -> float: ...
    @property
    def gravity(self) -> float: ...
    @property
    def block_names(self) -> list[str]: ...
    @property
    def source(self) -> str: ...
    def to_dict(self) -> dict[str, Any]: ...
    def to_json(self) -> str: ...
    def layout(self) -> list[dict[str, Any]]: ...
    def friction_between(self, lower: int | None, upper: int) -> float: ...
    def ground_motion(self, t: npt.ArrayLike) -> dict[str, npt.NDArray[np.float64]]: ...
    def excitation_breakpoints(self) -> list[float]: ...

@final
class Run:
    """The result of one engine run."""

    @property
    def engine(self) -> str: ...
    @property
    def t(self) -> npt.NDArray[np.float64]: ...
    @property
    def blocks(self) -> dict[str, dict[str, npt.NDArray[np.float64]]]: ...
    @property
    def summary(self) -> dict[str, Any]: ...

def load_scene(
    source: str | os.PathLike[str] | dict[str, Any], overrides: Sequence[str] = ...
) -> Scene: ...
def run(
    scene: Scene | str | os.PathLike[str] | dict[str, Any],
    engine: str = "native",
    overrides: Sequence[str] = ...,
) -> Run: ...
def engine_names() -> list[str]: ...
def check_engine_names(what: str, names: Sequence[str]) -> None: ...
def check_study_out(out: str | os.PathLike[str], cache: str | os.PathLike[str]) -> str: ...
def compare_rows(
    scene: Scene | str | os.PathLike[str] | dict[str, Any],
    engines: Sequence[str],
    reference: str = "native",
    overrides: Sequence[str] = ...,
) -> tuple[list[dict[str, Any]], dict[str, str]]: ...
def fragility_study(
    study: str | os.PathLike[str],
    out: str | os.PathLike[str] | None = None,
    quiet: bool = True,
    cache: str | os.PathLike[str] | None = None,
    command: str | None = None,
) -> dict[str, Any]: ...
def fragility_run_specs(study: str | os.PathLike[str]) -> list[tuple[str, str]]: ...
def fragility_run(spec: str) -> str: ...
def fragility_cache_dir(study: str | os.PathLike[str]) -> str: ...
def fragility_ida_jobs(study: str | os.PathLike[str]) -> list[tuple[int, str, str]]: ...
def fragility_ida_batch(
    study: str | os.PathLike[str], jobs: Sequence[tuple[int, str, str]], cache: str | os.PathLike[str]
) -> tuple[int, int, list[tuple[str, str]]]: ...
def fragility_store(cache: str | os.PathLike[str], runs: Sequence[tuple[str, str]]) -> int: ...
def fragility_run_batch(
    specs: Sequence[str], cache: str | os.PathLike[str]
) -> list[tuple[str, bool, str]]: ...
def fragility_cache_has(cache: str | os.PathLike[str], keys: Sequence[str]) -> list[bool]: ...
def fragility_is_python_worker(engine: str) -> bool: ...
def fragility_worker_scene(spec: str) -> str: ...
def fragility_worker_early_stop(spec: str) -> str | None: ...
def fragility_worker_outcome(
    spec: str, out_dir: str | os.PathLike[str], wall_s: float, cache: str | os.PathLike[str]
) -> str: ...
