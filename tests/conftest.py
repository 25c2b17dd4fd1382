"""Shared fixtures: small deterministic volumes and their detected sources."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.datasets import MonopoleParams, make_monopole
from auralize.sources import SourceSeries, Thresholds, detect

MONO_KW = {"size": 32, "steps": 300}


@pytest.fixture(scope="session")
def mono_params() -> MonopoleParams:
    return MonopoleParams(**MONO_KW)


@pytest.fixture(scope="session")
def mono_volume():  # type: ignore[no-untyped-def]
    return make_monopole(**MONO_KW).load()


@pytest.fixture(scope="session")
def mono_series(mono_volume) -> SourceSeries:  # type: ignore[no-untyped-def]
    return detect(mono_volume, mapping="identity", thresholds=Thresholds(monopole="0.1%"))


@pytest.fixture(scope="session")
def mono_tracks(mono_series):  # type: ignore[no-untyped-def]
    return mono_series.tracks()


def rng() -> np.random.Generator:
    return np.random.default_rng(1234)
