"""Progress bars for long work: tqdm on stderr, off when not wanted."""

from __future__ import annotations

import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")


def progress(it: Iterable[T], *, desc: str, enabled: bool = True, total: int | None = None,
             unit: str = "it") -> Iterator[T]:  # fmt: skip
    """Wrap ``it`` in a tqdm bar on stderr when ``enabled`` and stderr is a terminal."""
    if not enabled or not sys.stderr.isatty():
        yield from it
        return
    from tqdm import tqdm

    yield from tqdm(it, desc=desc, total=total, unit=unit, leave=False, file=sys.stderr)
