"""SOFA (AES69) head-related impulse responses: read and write.

A SOFA file is netCDF-4, i.e. HDF5 (read here with ``h5py``).  The
``SimpleFreeFieldHRIR`` convention (AES69-2015 / -2022, §"Conventions") stores

* global attributes ``Conventions = "SOFA"``, ``SOFAConventions``,
  ``DataType = "FIR"`` (plus version, author and licence attributes);
* ``Data.IR`` (M, R, N): M measurements, R = 2 receivers (left, right ear),
  N taps;
* ``Data.SamplingRate`` (I,) or (M,), attribute ``Units = "hertz"``;
* ``SourcePosition`` (M, C) or (I, C), attributes ``Type = "spherical"``
  (azimuth °, elevation °, distance m; ``Units = "degree, degree, metre"``)
  or ``"cartesian"`` (metres);
* optional ``Data.Delay`` (I, R) or (M, R): broadband delays in samples
  added to the responses; ``ListenerView``/``ListenerUp`` (I, C): the
  listener's orientation (default x forward, z up), and ``ListenerPosition``.

Any FIR convention with these variables is read (SimpleFreeFieldHRIR, and
GeneralFIR files with two receivers).  SOFA's coordinate system is the listener frame of :mod:`auralize.spatial.layouts`
(x forward, y left, z up; azimuth counter-clockwise), so source positions map
directly to directions once the listener's view and up are taken out.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import FormatError, MissingFileError
from auralize.spatial.hrtf import HRIRSet


def _text(v: Any) -> str:
    if isinstance(v, bytes | np.bytes_):
        return v.decode("utf-8", "replace")
    if isinstance(v, np.ndarray):
        return _text(v.reshape(-1)[0]) if v.size else ""
    return str(v)


def _var(h: Any, path: Path, name: str, *, required: bool = True) -> NDArray[np.float64] | None:
    if name not in h:
        if required:
            raise FormatError(
                f"{path}: SOFA variable {name!r} is missing (AES69 SimpleFreeFieldHRIR)"
            )
        return None
    try:
        a = np.asarray(h[name][()], dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise FormatError(f"{path}: SOFA variable {name!r} is not numeric ({exc})") from None
    if not np.all(np.isfinite(a)):
        raise FormatError(f"{path}: SOFA variable {name!r} has NaN or infinite values")
    return a


def _to_cartesian(
    pos: NDArray[np.float64], kind: str, units: str, path: Path, name: str
) -> NDArray[np.float64]:
    if kind == "cartesian":
        return pos
    if kind != "spherical":
        raise FormatError(f"{path}: {name} has Type={kind!r}; expected 'spherical' or 'cartesian'")
    ang = pos[:, :2]
    if "rad" not in units.split(",")[0]:  # degrees (the convention's unit)
        ang = np.deg2rad(ang)
    az, el, r = ang[:, 0], ang[:, 1], pos[:, 2]
    r = np.where(r > 0, r, 1.0)
    return np.stack([r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)], 1)


def _attrs(ds: Any) -> tuple[str, str]:
    return _text(ds.attrs.get("Type", "cartesian")).strip().lower(), _text(
        ds.attrs.get("Units", "")
    ).strip().lower()


def read_sofa(path: str | Path) -> HRIRSet:
    """Read an AES69 SimpleFreeFieldHRIR file into an :class:`~auralize.spatial.hrtf.HRIRSet`.

    Source positions are turned into unit directions in the listener frame
    (the file's listener position, view and up taken out); ``Data.Delay`` is
    applied to the responses.

    Parameters
    ----------
    path : str or Path
        The SOFA file.

    Returns
    -------
    HRIRSet
        ``source`` is the file name; ``meta`` holds its conventions, title,
        licence, organisation, database and listener names when given.

    Raises
    ------
    MissingFileError
        The file does not exist.
    FormatError
        Not HDF5/netCDF-4, not SOFA, a data type other than FIR, a missing or
        misshapen variable (the message names it and the expected shape), not
        two receivers, or a sampling rate that is not one positive value; or
        the file reads data from other files (external links, external
        storage, virtual datasets) and :func:`auralize.runtime.hdf5safe.allow_external_data`
        does not allow it (``--allow-external``, ``AURALIZE_HDF5_EXTERNAL=1``).

    Examples
    --------
    >>> from auralize.spatial.hrtf import spherical_head_hrirs
    >>> hrirs = spherical_head_hrirs(np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]), 8000)
    >>> back = read_sofa(write_sofa("head.sofa", hrirs))
    >>> back.rate, back.ir.shape, np.allclose(back.ir, hrirs.ir), np.round(back.directions, 9).tolist()
    (8000, (3, 2, 32), True, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    >>> read_sofa("missing.sofa")
    Traceback (most recent call last):
    auralize.errors.MissingFileError: SOFA file 'missing.sofa' does not exist
    """
    import h5py

    p = Path(path)
    if not p.is_file():
        raise MissingFileError(f"SOFA file {str(p)!r} does not exist")
    try:
        h = h5py.File(p, "r")
    except OSError as exc:
        raise FormatError(f"{p}: not a SOFA file (not netCDF-4/HDF5: {exc})") from None
    with h:
        from auralize.runtime.hdf5safe import check_self_contained

        check_self_contained(h, p)  # HRIRs stored in /etc/passwd are refused
        conv = _text(h.attrs.get("Conventions", ""))
        if conv != "SOFA":
            raise FormatError(
                f"{p}: not a SOFA file: global attribute 'Conventions' is {conv!r}, expected 'SOFA'"
            )
        sconv = _text(h.attrs.get("SOFAConventions", ""))
        dtype = _text(h.attrs.get("DataType", "FIR"))
        if not dtype.startswith("FIR"):
            raise FormatError(f"{p}: SOFA DataType {dtype!r} is not supported; expected 'FIR'")
        ir = _var(h, p, "Data.IR")
        assert ir is not None
        if ir.ndim != 3 or ir.shape[1] != 2 or ir.shape[0] < 1 or ir.shape[2] < 1:
            raise FormatError(
                f"{p}: Data.IR must be (M, R=2, N) (measurements, left/right ear, taps), "
                f"got shape {ir.shape}"
            )
        m = ir.shape[0]
        fs = _var(h, p, "Data.SamplingRate")
        assert fs is not None
        fs = fs.reshape(-1)
        if fs.size == 0 or not np.all(fs == fs[0]) or not fs[0] > 0:
            raise FormatError(
                f"{p}: Data.SamplingRate must be one positive rate in hertz, got {fs.tolist()}"
            )
        rate = float(fs[0])
        if abs(rate - round(rate)) > 1e-6:
            raise FormatError(f"{p}: Data.SamplingRate {rate} Hz is not a whole number of hertz")
        pos = _var(h, p, "SourcePosition")
        assert pos is not None
        if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] not in (1, m):
            raise FormatError(
                f"{p}: SourcePosition must be (M={m}, C=3) or (1, 3), got shape {pos.shape}"
            )
        pos = _to_cartesian(
            np.broadcast_to(pos, (m, 3)).copy(), *_attrs(h["SourcePosition"]), p, "SourcePosition"
        )
        lpos = _var(h, p, "ListenerPosition", required=False)
        if lpos is not None and lpos.size >= 3:
            lp = _to_cartesian(
                lpos.reshape(-1, 3), *_attrs(h["ListenerPosition"]), p, "ListenerPosition"
            )
            if lp.shape[0] in (1, m):
                pos = pos - lp
        view = _var(h, p, "ListenerView", required=False)
        up = _var(h, p, "ListenerUp", required=False)
        if view is not None and view.size >= 3:
            from auralize.spatial.layouts import listener_frame

            f = _to_cartesian(
                view.reshape(-1, 3)[:1], *_attrs(h["ListenerView"]), p, "ListenerView"
            )
            u = (
                np.array([[0.0, 0.0, 1.0]])
                if up is None or up.size < 3
                else _to_cartesian(up.reshape(-1, 3)[:1], *_attrs(h["ListenerUp"]), p, "ListenerUp")
            )
            f = f / np.linalg.norm(f)
            u = u - np.sum(u * f) * f
            if not np.linalg.norm(u) > 1e-9:
                raise FormatError(f"{p}: ListenerUp is parallel to ListenerView")
            pos = listener_frame(pos, f, u / np.linalg.norm(u))
        if not np.all(np.linalg.norm(pos, axis=1) > 0):
            raise FormatError(f"{p}: SourcePosition has a source at the listener's position")
        delay = _var(h, p, "Data.Delay", required=False)
        meta: dict[str, object] = {"conventions": sconv, "file": str(p)}
        for k in ("Title", "License", "Organization", "DatabaseName", "ListenerShortName"):
            if k in h.attrs:
                meta[k.lower()] = _text(h.attrs[k])
    if delay is not None and np.any(delay != 0):
        if delay.ndim != 2 or delay.shape[1] != 2 or delay.shape[0] not in (1, m):
            raise FormatError(f"{p}: Data.Delay must be (1, 2) or (M={m}, 2), got {delay.shape}")
        ir = _apply_delay(ir, np.broadcast_to(delay, (m, 2)))
    return HRIRSet(ir, pos, int(round(rate)), None, str(p), meta)


def _apply_delay(ir: NDArray[np.float64], delay: NDArray[np.float64]) -> NDArray[np.float64]:
    """Responses delayed by ``delay (M, 2)`` samples (fractional, in frequency)."""
    if np.any(delay < 0):
        raise FormatError(f"Data.Delay must be ≥ 0 samples, got {float(delay.min())}")
    n = ir.shape[2] + int(math.ceil(float(delay.max())))
    n_fft = 2 * n
    f = np.fft.rfftfreq(n_fft)
    spec = np.fft.rfft(ir, n_fft, axis=-1) * np.exp(-2j * np.pi * f * delay[..., None])
    return np.fft.irfft(spec, n_fft, axis=-1)[..., :n]


def write_sofa(
    path: str | Path, hrirs: HRIRSet, *, title: str = "auralize HRIRs", license_: str = "CC0-1.0"
) -> Path:
    """Write an :class:`~auralize.spatial.hrtf.HRIRSet` as AES69 SimpleFreeFieldHRIR.

    netCDF-4 dimensions (M, R, N, I, C, E) are HDF5 dimension scales, so
    netCDF and SOFA readers open the file; positions are spherical (degrees,
    distance 1 m).  Written atomically (a temporary file, then renamed;
    :func:`~auralize.runtime.files.atomic_hdf5`): a failed write raises one
    :class:`~auralize.errors.OutputError` and leaves nothing behind.

    Parameters
    ----------
    path : str or Path
        The file to write (``.sofa``).
    hrirs : HRIRSet
        The responses and their directions.
    title : str
        The file's ``Title`` attribute.
    license_ : str
        The file's ``License`` attribute.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OutputError
        The file cannot be written (or the disk is too small for it).

    Examples
    --------
    >>> import h5py
    >>> from auralize.spatial.hrtf import spherical_head_hrirs
    >>> out = write_sofa("model.sofa", spherical_head_hrirs(np.eye(3), 8000), title="model")
    >>> with h5py.File(out) as h:
    ...     h.attrs["SOFAConventions"], h.attrs["Title"], h["Data.IR"].shape
    ('SimpleFreeFieldHRIR', 'model', (3, 2, 32))
    """
    from auralize.runtime.files import atomic_hdf5, stop_if_failed

    p = Path(path)
    d = hrirs.directions
    az = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    el = np.degrees(np.arcsin(np.clip(d[:, 2], -1.0, 1.0)))
    m, _, n = hrirs.ir.shape
    nbytes = 8.0 * hrirs.ir.size + 24.0 * m + 65536.0  # responses, directions, overhead
    what = f"{m} HRIR pairs of {n} samples"
    with atomic_hdf5(p, suffix=".sofa.part", nbytes=nbytes, what=what) as h:
        for k, v in {
            "Conventions": "SOFA",
            "Version": "2.1",
            "SOFAConventions": "SimpleFreeFieldHRIR",
            "SOFAConventionsVersion": "1.0",
            "DataType": "FIR",
            "RoomType": "free field",
            "Title": title,
            "License": license_,
            "APIName": "auralize",
            "APIVersion": "1",
            "AuthorContact": "",
            "Organization": "",
            "DateCreated": "",
            "DateModified": "",
            "ListenerShortName": hrirs.source,
        }.items():
            h.attrs[k] = v
        dims = {"M": m, "R": 2, "N": n, "I": 1, "C": 3, "E": 1}
        for name, size in dims.items():  # netCDF-4 dimensions without coordinate variables
            ds = h.create_dataset(name, data=np.zeros(size, dtype="f4"))
            ds.make_scale(f"This is a netCDF dimension but not a netCDF variable.{size:10d}")

        def var(name: str, data: NDArray[np.float64], dim: tuple[str, ...], **attrs: str) -> None:
            ds = h.create_dataset(name, data=data)
            for i, dn in enumerate(dim):
                ds.dims[i].attach_scale(h[dn])
            for k, v in attrs.items():
                ds.attrs[k] = v

        var("ListenerPosition", np.zeros((1, 3)), ("I", "C"), Type="cartesian", Units="metre")
        var(
            "ListenerView", np.array([[1.0, 0.0, 0.0]]), ("I", "C"), Type="cartesian", Units="metre"
        )
        var("ListenerUp", np.array([[0.0, 0.0, 1.0]]), ("I", "C"), Type="cartesian", Units="metre")
        var(
            "ReceiverPosition",
            np.array([[[0.0], [0.0875], [0.0]], [[0.0], [-0.0875], [0.0]]]),
            ("R", "C", "I"),
            Type="cartesian",
            Units="metre",
        )
        var(
            "SourcePosition",
            np.stack([az, el, np.ones(m)], 1),
            ("M", "C"),
            Type="spherical",
            Units="degree, degree, metre",
        )
        var(
            "EmitterPosition", np.zeros((1, 3, 1)), ("E", "C", "I"), Type="cartesian", Units="metre"
        )
        var("Data.IR", hrirs.ir, ("M", "R", "N"))
        stop_if_failed(h)
        var("Data.SamplingRate", np.array([float(hrirs.rate)]), ("I",), Units="hertz")
        var("Data.Delay", np.zeros((1, 2)), ("I", "R"))
    return p
