"""auralize: hear 3-D time-varying data.

The obvious entries, as ``pyvista.read`` and ``xarray.open_dataset`` are:

* :func:`open` a volume file (whatever the readers open) or a built-in dataset;
* :func:`detect` its monopole, dipole and quadrupole sources;
* :func:`render` the sound heard along a listener path.

:mod:`auralize.simple` is the pvpython-style layer on top, :mod:`auralize.pipeline`
the functions behind these three.

``import auralize`` opens no window and no sound device; the GUI (``auralize.viewer``)
and the audio device layer (``auralize.audio.output``) are imported only when used, and
it changes no process-wide setting (the numba kernels' settings apply when a
kernel module is first imported, see :mod:`auralize.runtime.jit`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from auralize.errors import AuralizeError
from auralize.volume import TimeVolume

if TYPE_CHECKING:
    from pathlib import Path

    from auralize.emitters.synthesis import Rendered
    from auralize.listener import ListenerPath
    from auralize.sources.detection import SourceSeries

__version__ = "0.1.0"

__all__ = ["AuralizeError", "TimeVolume", "__version__", "detect", "open", "render"]


def open(spec: str | Path, **options: Any) -> TimeVolume:
    """Open a volume file, or a dataset that comes with auralize (``"dataset:NAME"``).

    The one opener: ``auralize.io.open_volume`` (files) and
    :func:`auralize.simple.OpenDataFile` go the same way
    (:func:`auralize.pipeline.load`).

    Parameters
    ----------
    spec : str or Path
        A file any reader opens (HDF5, VTK, netCDF, EnSight, Exodus, PLOT3D, ...),
        ``dataset:NAME`` (generated: ``explosion``, ``monopole``, ...; shipped:
        ``cavity``, ``pulse``, ...).
    **options
        The readers' options (:func:`auralize.pipeline.load`): ``size``,
        ``steps`` and ``seed`` of a generated dataset; ``fields``,
        ``resolution``, ``nan``, ``time_dim``, ``axis_scale``, ``box``.

    Returns
    -------
    TimeVolume

    Raises
    ------
    MissingFileError, FormatError, DataError
        The file is missing, unreadable or holds no usable time series.

    Examples
    --------
    >>> import auralize
    >>> vol = auralize.open("dataset:monopole", size=12, steps=8)
    >>> vol.dims, vol.n_steps
    ((12, 12, 12), 8)
    """
    from auralize.pipeline import load

    return load(spec, **options)


def detect(volume: TimeVolume | str | Path, **options: Any) -> SourceSeries:
    """Detect the monopole, dipole and quadrupole sources of ``volume`` at every step
    (paper 003 §3.2; as ``auralize detect``).

    Parameters
    ----------
    volume : TimeVolume, or what :func:`open` takes
    **options
        ``mapping``, ``thresholds`` (a :class:`~auralize.sources.detection.Thresholds`),
        ``progress_bar`` and the mapping's field names
        (:func:`auralize.pipeline.detect_sources`).

    Returns
    -------
    SourceSeries

    Examples
    --------
    >>> import auralize
    >>> series = auralize.detect(auralize.open("dataset:monopole", size=12, steps=30))
    >>> series.n_steps, sum(c["monopole"] for c in series.counts()) > 0
    (30, True)
    """
    from auralize.pipeline import detect_sources, load

    return detect_sources(load(volume) if not isinstance(volume, TimeVolume) else volume, **options)


def render(
    volume: TimeVolume | str | Path, path: ListenerPath | None = None, **options: Any
) -> Rendered:
    """The sound heard along ``path`` from ``volume``, as ``auralize render`` makes it.

    :func:`auralize.pipeline.auralize` with the defaults of every front end
    (:data:`auralize.defaults.DEFAULTS`: the whole field heard, an orbit when
    there is no path, ``time_scale="auto"``, ``timbre="auto"``, a 20 Hz high-pass,
    mono at 44.1 kHz).

    Parameters
    ----------
    volume : TimeVolume, or what :func:`open` takes
    path : ListenerPath, optional
        Where the listener goes (default: an orbit around the data).
    **options
        As :func:`auralize.pipeline.auralize`: ``layout``, ``rate``,
        ``duration``, ``time_scale``, ``heard``, ``timbre``, ``listener``, ...

    Returns
    -------
    Rendered
        ``audio (n_channels, n_samples)`` in pascals; write it with
        :func:`auralize.pipeline.save_rendered`.

    Examples
    --------
    >>> import auralize
    >>> r = auralize.render("dataset:monopole", size=12, steps=30, duration=0.1,
    ...                     layout="stereo")
    >>> r.audio.shape
    (2, 4410)
    """
    from auralize.pipeline import auralize, load

    if not isinstance(volume, TimeVolume):
        opening = {
            k: options.pop(k)
            for k in (
                "size",
                "steps",
                "seed",
                "fields",
                "resolution",
                "nan",
                "time_dim",
                "axis_scale",
                "box",
            )
            if k in options
        }
        volume = load(volume, **opening)
    return auralize(volume, path, **options)[0]
