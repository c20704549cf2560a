"""Studies: sweeps of rigs × sensors × waters × distances × targets → a tidy results table.

Each scene is rendered once and captured by every sensor; results are written
atomically per case, so an interrupted study resumes where it stopped.  Cases run
on dask.distributed (an embedded local cluster by default, or ``scheduler=ADDRESS``).
"""

from rigsim.study.spec import StudySpec, load_study
from rigsim.study.runner import run_study

__all__ = ["StudySpec", "load_study", "run_study"]
