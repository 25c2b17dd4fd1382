"""Datasets: synthetic generators, the shipped real data, and opening either by name.

* :mod:`auralize.datasets.synthetic` — analytic monopole and explosion
  volumes and the dataset registry (the public names below);
* :mod:`auralize.datasets.real` — the real datasets shipped in ``auralize/data``;
* :mod:`auralize.datasets.shipped` — their files, unpacked on first use;
* :mod:`auralize.datasets.opener` — :func:`~auralize.datasets.opener.load`: a
  volume file or ``dataset:NAME`` (what :func:`auralize.pipeline.load` is).

The figures they must keep producing are :mod:`auralize.regression`'s.
"""

from auralize.runtime.lazy import lazy_exports

#: exported name -> sub-module, imported on first access
_EXPORTS = {
    "MonopoleParams": ".synthetic",
    "make_monopole": ".synthetic",
    "monopole_pressure": ".synthetic",
    "ExplosionParams": ".synthetic",
    "make_explosion": ".synthetic",
    "DATASETS": ".synthetic",
    "DEFAULT_MAPPING": ".synthetic",
    "all_datasets": ".synthetic",
    "make_dataset": ".synthetic",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = [
    "DATASETS",
    "DEFAULT_MAPPING",
    "ExplosionParams",
    "MonopoleParams",
    "all_datasets",
    "make_dataset",
    "make_explosion",
    "make_monopole",
    "monopole_pressure",
]
