"""``python -m rockbench.study STUDY.toml [--scheduler ADDRESS] [--out DIR] [--cache DIR]``: a
fragility study on a Dask cluster (with ``--scheduler``) or here. The implementation, and the
Python API (``fragility``, ``run_many``), is ``rockbench.studies``."""

from __future__ import annotations

import sys

from rockbench.studies import TASK_SECONDS, distribute, fragility, main, run_many, task_size

__all__ = ["TASK_SECONDS", "distribute", "fragility", "main", "run_many", "task_size"]

if __name__ == "__main__":
    sys.exit(main())
