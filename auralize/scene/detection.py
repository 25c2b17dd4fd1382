"""Source detection the viewer can show step by step, interrupt and resume.

:class:`Detection` prepares the mapping and resolves the thresholds once, then
detects single steps on demand (the time slider shows sources of the current
step at once) or all steps with a progress callback that may cancel.  It
wraps :func:`auralize.sources.detection.iter_detect`; no physics lives here.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import numpy as np

from auralize.defaults import DEFAULTS
from auralize.errors import AuralizeError
from auralize.errors import Cancelled as Cancelled  # (re-exported: the viewer's tasks raise it)
from auralize.sources.detection import (
    SourceFrame,
    SourceSeries,
    Thresholds,
    iter_detect,
    require_steps,
    steady_strength,
    strength_stats,
)
from auralize.sources.mapping import AcousticMapping
from auralize.volume import TimeVolume

#: the viewer's default thresholds: those of every front end (``auto`` for each
#: type, :data:`auralize.defaults.DEFAULTS`), so that the viewer draws the
#: sources ``auralize detect`` finds
VIEWER_THRESHOLDS: tuple[str, str, str] = DEFAULTS.thresholds


class Detection:
    """Mapping + thresholds of one volume, and the source frames detected so far.

    Parameters
    ----------
    volume : TimeVolume
    mapping : str or AcousticMapping, optional
        Default :func:`auralize.pipeline.auto_mapping`.
    thresholds : Thresholds, optional
        Default :data:`VIEWER_THRESHOLDS`.

    Examples
    --------
    >>> from auralize.datasets.synthetic import make_monopole
    >>> det = Detection(make_monopole(size=12, steps=6), mapping="identity")
    >>> det.frame(3).counts()["monopole"] > 0
    True
    """

    def __init__(
        self,
        volume: TimeVolume,
        *,
        mapping: str | AcousticMapping | None = None,
        thresholds: Thresholds | None = None,
        **mapping_fields: str,
    ) -> None:
        from auralize.pipeline import resolve_mapping

        require_steps(volume)
        self.volume = volume
        self.mapping = resolve_mapping(volume, mapping, **mapping_fields)
        self.mapping.prepare(volume)
        self.thresholds = thresholds or Thresholds(*VIEWER_THRESHOLDS)
        # strengths of the time-varying part, as auralize.sources.detection.detect takes them
        self.qmean = steady_strength(volume, self.mapping)
        stats = (
            strength_stats(volume, self.mapping, qmean=self.qmean)
            if self.thresholds.needs_scale
            else None
        )
        self.peak = None if stats is None else stats.peak
        self.thr = self.thresholds.resolve(stats)
        self.frames: dict[int, SourceFrame] = {}
        self._lock = threading.Lock()

    def frame(self, step: int) -> SourceFrame:
        """Sources of one step (detected now if not yet)."""
        with self._lock:
            if step not in self.frames:
                for n, f in iter_detect(
                    self.volume,
                    self.mapping,
                    self.thr,
                    zero_fraction=self.thresholds.zero_fraction,
                    steps=range(step, step + 1),
                    qmean=self.qmean,
                ):
                    self.frames[n] = f
            return self.frames[step]

    def get(self, step: int) -> SourceFrame | None:
        """Sources of a step if already detected, else None (never blocks on detection)."""
        return self.frames.get(step)

    def run(self, progress: Callable[[int, int], bool | None] | None = None) -> SourceSeries:
        """Detect every step not yet done; ``progress(done, total)`` returning False cancels
        (raises :class:`Cancelled`; the steps done so far are kept)."""
        todo = [n for n in range(self.volume.n_steps) if n not in self.frames]
        total = self.volume.n_steps
        done = total - len(todo)
        # consecutive runs reuse the mapped neighbour frames inside iter_detect
        runs: list[range] = []
        for n in todo:
            if runs and runs[-1].stop == n:
                runs[-1] = range(runs[-1].start, n + 1)
            else:
                runs.append(range(n, n + 1))
        for r in runs:
            for n, f in iter_detect(
                self.volume,
                self.mapping,
                self.thr,
                zero_fraction=self.thresholds.zero_fraction,
                steps=r,
                qmean=self.qmean,
            ):
                with self._lock:
                    self.frames[n] = f
                done += 1
                if progress is not None and progress(done, total) is False:
                    raise Cancelled(f"detection cancelled after {done} of {total} steps")
        return self.series()

    @property
    def complete(self) -> bool:
        return len(self.frames) == self.volume.n_steps

    def series(self) -> SourceSeries:
        """The detected :class:`SourceSeries` (all steps must be done)."""
        if not self.complete:
            missing = self.volume.n_steps - len(self.frames)
            raise AuralizeError(f"{missing} time steps are not detected yet; run detection first")
        vol = self.volume
        return SourceSeries(
            frames=[self.frames[n] for n in range(vol.n_steps)],
            times=vol.times.copy(),
            origin=vol.origin.copy(),
            spacing=vol.spacing.copy(),
            dims=vol.dims,
            thresholds=np.asarray(self.thr, dtype=np.float64).copy(),
            meta={
                "mapping": self.mapping.describe(),
                "thresholds": self.thresholds.describe(),
                "peak": None if self.peak is None else self.peak.tolist(),
                "source": vol.source,
            },
            coords=vol.coords,
        )

    def counts(self, step: int) -> dict[str, int] | None:
        f = self.frames.get(step)
        return None if f is None else f.counts()
