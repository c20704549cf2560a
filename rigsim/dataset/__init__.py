"""Training data with ground truth: randomized underwater scenes rendered and captured at scale.

``rigsim dataset SPEC.toml --n N --out DIR`` draws N samples from the distributions of
a dataset spec (:mod:`rigsim.dataset.spec`), renders and captures each
(:mod:`rigsim.dataset.sample`), and writes them with their ground truth in the layout
documented in :mod:`rigsim.dataset.writer`.
"""

from rigsim.dataset.spec import DatasetSpec, load_dataset_spec
from rigsim.dataset.writer import run_dataset

__all__ = ["DatasetSpec", "load_dataset_spec", "run_dataset"]
