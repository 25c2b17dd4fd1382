"""Dataset regression: figures the shipped and generated datasets must keep producing.

* :mod:`auralize.regression.synthetic` — the built-in generated datasets
  (``python -m auralize.regression.synthetic [--update]``);
* :mod:`auralize.regression.real` — the real datasets shipped in
  ``auralize/data/`` (``python -m auralize.regression.real [--update]``).

Both run the whole pipeline, so they sit above it (the datasets themselves,
:mod:`auralize.datasets`, sit below).
"""
