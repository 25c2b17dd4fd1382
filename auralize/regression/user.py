"""Regression checks of a user's own data: does this run still detect and sound as before?

:func:`record` runs the pipeline on a dataset with given settings (reading,
detection, listener path, layout, rate ...) and stores in one JSON file
what came out, plus a picture beside it; :func:`check` runs it again with the
stored settings and names every figure that moved beyond its tolerance.
``auralize regress record|check`` and the ``auralize_regression`` pytest
fixture (:mod:`auralize.regression.pytest_plugin`) are this module.

The figures (:func:`compute`):

* **counts** — source points per type at every step (``counts step N TYPE``),
  and each type's **onset** and **end**: the first and the last step with
  points of that type (``onset TYPE``, ``end TYPE``);
* along the listener path, in :data:`DEFAULT_WINDOWS` equal windows of
  playback time: the **level** (dB re 20 µPa of the mean square over the
  window, the channels averaged: ``level window K (A–B s)``), the spectral
  **centroid** (Hz, of the channels' summed power spectra) and the
  ⅓-octave **band** levels (:func:`auralize.spectrum.spectrum`, channels'
  energies averaged: ``band F Hz window K``);
* the **image**: an off-screen picture of the data with its sources and the
  path at the step with the most sources (:func:`auralize.scene.pictures.screenshot`),
  stored as ``EXPECT.png`` beside ``EXPECT.json``, compared by the RMS of
  the pixel difference (0..255 per channel).

The tolerances (:data:`DEFAULT_TOLERANCES`, stored with the figures; both
``record`` and ``check`` take overrides): ``counts`` relative (and at least
``counts_at_least`` points), ``onset`` steps, ``level`` dB, ``centroid``
relative, ``bands`` dB, ``image`` RMS levels.  Windows whose expected level
is more than :data:`QUIET_DB` below the loudest window are compared as
levels only (their centroid and bands are noise), and bands more than
:data:`QUIET_DB` below a window's loudest band are not compared.

The path the listener took is stored (its captures), so a check renders
along the same path whatever the planning does; without ``path`` or
``listener`` it is the default orbit of ``auralize render``.
"""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from auralize import __version__
from auralize.defaults import DEFAULTS
from auralize.errors import FormatError, MissingFileError, ParameterError
from auralize.regression.compare import (
    TYPES,
    Moved,
    count_changes,
    db_change,
    image_rms,
    relative_change,
    spectral_centroid,
    step_change,
)

__all__ = [
    "DEFAULT_SETTINGS",
    "DEFAULT_TOLERANCES",
    "DEFAULT_WINDOWS",
    "FORMAT",
    "CheckResult",
    "check",
    "compare",
    "compute",
    "record",
    "tolerances_from",
]

#: the ``format`` entry of an expectation file, and its version
FORMAT = "auralize-regression"
VERSION = 1
#: windows of playback time along the path
DEFAULT_WINDOWS = 8
#: windows (and bands) this far below the loudest (dB) are compared as levels only
QUIET_DB = 60.0
#: the kinds of figure, in the order a summary names them
GROUPS = ("counts", "onset", "level", "centroid", "bands", "image")
#: moved figures a summary lists one by one
SUMMARY_LINES = 20
#: the tolerance of each kind of figure (see the module docstring)
DEFAULT_TOLERANCES: dict[str, float] = {
    "counts": 0.05,  # relative
    "counts_at_least": 2,  # points
    "onset": 0,  # steps (onsets and ends)
    "level": 1.0,  # dB
    "centroid": 0.05,  # relative
    "bands": 3.0,  # dB
    "image": 2.0,  # RMS of 0..255 levels
}
#: what is read, detected and rendered, and how (the options of ``auralize render``)
DEFAULT_SETTINGS: dict[str, Any] = {
    "read": {},  # size, steps, seed, fields, resolution, nan, time_dim, axis_scale, box, resample
    "mapping": None,
    "mapping_fields": {},
    "thresholds": list(DEFAULTS.thresholds),
    "zero_fraction": 1.0,
    "floor": 3.0,
    "listener": None,
    "duration": None,
    "time_scale": DEFAULTS.time_scale,
    "layout": DEFAULTS.layout,
    "rate": DEFAULTS.rate,
    "heard": DEFAULTS.heard,
    "timbre": DEFAULTS.timbre,
    "highpass_hz": DEFAULTS.highpass_hz,
    "interp": DEFAULTS.interp,
    "seed": 0,
    "method": DEFAULTS.method,
    "orbit_face": DEFAULTS.orbit_face,
    "windows": DEFAULT_WINDOWS,
    "screenshot": True,
    "screenshot_size": [480, 360],
}
_READ_KEYS = (
    "size",
    "steps",
    "seed",
    "fields",
    "resolution",
    "nan",
    "time_dim",
    "axis_scale",
    "box",
    "resample",
)


def settings_from(**given: Any) -> dict[str, Any]:
    """:data:`DEFAULT_SETTINGS` updated with ``given`` (unknown names are an error; the
    reader's options may be given flat, ``size=32``, or as ``read={...}``)."""
    out = json.loads(json.dumps(DEFAULT_SETTINGS))
    for k, v in given.items():
        if k in _READ_KEYS:
            if v is not None:
                out["read"][k] = v
        elif k == "read":
            out["read"].update({a: b for a, b in dict(v).items() if b is not None})
        elif k not in DEFAULT_SETTINGS and k != "path":
            raise ParameterError(
                f"regression setting {k!r} is not one of "
                f"{sorted([*DEFAULT_SETTINGS, 'path', *_READ_KEYS])}"
            )
        else:
            out[k] = v
    bad = [k for k in out["read"] if k not in _READ_KEYS]
    if bad:
        raise ParameterError(f"regression read option(s) {bad} unknown; they are {_READ_KEYS}")
    if not (isinstance(out["windows"], int) and out["windows"] >= 1):
        raise ParameterError(f"windows must be a whole number >= 1, got {out['windows']!r}")
    return out


def tolerances_from(base: dict[str, float] | None = None, **given: float) -> dict[str, float]:
    """Tolerances: ``base`` (default :data:`DEFAULT_TOLERANCES`) with ``given`` over it."""
    out = dict(DEFAULT_TOLERANCES)
    out.update(base or {})
    for k, v in given.items():
        if k not in DEFAULT_TOLERANCES:
            raise ParameterError(f"tolerance {k!r} is not one of {sorted(DEFAULT_TOLERANCES)}")
        if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
            raise ParameterError(f"tolerance {k}={v!r} must be a number >= 0")
        out[k] = float(v)
    return out


def _path_rows(path: Any) -> dict[str, Any]:
    return {"source": str(path.source), "rows": np.round(path.rows(), 12).tolist()}


def _path_from(stored: dict[str, Any]) -> Any:
    from auralize.listener import ListenerPath

    r = np.asarray(stored["rows"], dtype=np.float64).reshape(-1, 10)
    return ListenerPath(
        r[:, 0],
        r[:, 1:4],
        forward=r[:, 4:7],
        up=r[:, 7:10],
        source=f"the stored {stored.get('source', '')} path".replace("  ", " "),
    )


def _windows(n: int, rate: int, count: int) -> list[tuple[int, int]]:
    edges = np.linspace(0, n, count + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in itertools.pairwise(edges) if b - a >= 2]


def _figures_of_audio(audio: np.ndarray, rate: int, windows: int) -> dict[str, Any]:
    """Level, centroid and ⅓-octave bands in each window (see the module docstring)."""
    from auralize.spectrum import P_REF, spectrum

    spans = _windows(audio.shape[1], rate, windows)
    level, centroid, bands = [], [], []
    centres: list[float] = []
    labels: list[str] = []
    for a, b in spans:
        x = audio[:, a:b]
        ms = float(np.mean(x**2))
        # silence (no level, no centroid) is stored as null: the file stays plain JSON
        level.append(10 * math.log10(ms / P_REF**2) if ms > 0 else None)
        centroid.append(spectral_centroid(x, rate) if ms > 0 else None)
        s = spectrum(x, rate)
        with np.errstate(divide="ignore"):
            energy = np.mean(10 ** (s.band_levels / 10), axis=0)
            db = 10 * np.log10(np.where(energy > 0, energy, 1.0))
            bands.append([float(v) if e > 0 else None for v, e in zip(db, energy, strict=True)])
        centres, labels = s.band_centres.tolist(), list(s.band_labels)
    return {
        "windows_s": [[a / rate, b / rate] for a, b in spans],
        "level_db": level,
        "centroid_hz": centroid,
        "band_centres_hz": centres,
        "band_labels": labels,
        "band_levels_db": bands,
        "rms_pa": float(np.sqrt(np.mean(audio**2))) if audio.size else 0.0,
    }


def _detection_args(st: dict[str, Any]) -> dict[str, Any]:
    from auralize.sources.detection import Thresholds

    mono, di, quad = st["thresholds"]
    th = Thresholds(mono, di, quad, zero_fraction=st["zero_fraction"], floor=st["floor"])
    return {"mapping": st["mapping"], "thresholds": th, **dict(st["mapping_fields"])}


def compute(
    data: str | Path, settings: dict[str, Any], *, path: Any = None, image: str | Path | None = None
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The figures of ``data`` with ``settings`` (:func:`settings_from`), along ``path``
    (a :class:`~auralize.listener.ListenerPath`; default: ``settings["listener"]``,
    else the default orbit of ``auralize render``); the picture is written to
    ``image`` if given.

    Returns
    -------
    (figures, path) : the figures, and the path rendered along (its captures, for
    :func:`record` to store).
    """
    from auralize.io.options import curvilinear_mode
    from auralize.listener import ListenerPath
    from auralize.pipeline import auralize, detect_sources, heard_tracks, load, plan_render
    from auralize.sources.field import parse_heard

    st = settings
    read = dict(st["read"])
    with curvilinear_mode("resample" if read.pop("resample", False) else "native"):
        vol = load(str(data), **read)
    series = detect_sources(vol, **_detection_args(st))
    counts = series.counts()
    duration = st["duration"]
    if path is None and st["listener"] is not None:
        path = ListenerPath.point(st["listener"], duration=duration or DEFAULTS.duration)
    if path is None:  # the default orbit, as auralize render plans it
        hd = parse_heard(st["heard"])
        tracks = heard_tracks(series, hd) if hd.mode == "detected" else None
        plan = plan_render(
            vol, tracks, duration=duration, time_scale=st["time_scale"], face=st["orbit_face"]
        )
        path, duration = plan.path, plan.duration
    series_arg = series if parse_heard(st["heard"]).mode == "detected" else None
    out, _ = auralize(
        vol,
        path,
        series=series_arg,
        rate=st["rate"],
        time_scale=st["time_scale"],
        interp=st["interp"],
        layout=st["layout"],
        duration=duration,
        timbre=st["timbre"],
        highpass_hz=st["highpass_hz"],
        seed=st["seed"],
        heard=st["heard"],
        method=st["method"],
        orbit_face=st["orbit_face"],
        **_detection_args(st),
    )
    figures: dict[str, Any] = {
        "steps": vol.n_steps,
        "times": vol.times.tolist(),
        "counts": counts,
        "onset": {k: next((n for n, c in enumerate(counts) if c[k]), None) for k in TYPES},
        "end": {
            k: next((n for n in range(len(counts) - 1, -1, -1) if counts[n][k]), None)
            for k in TYPES
        },
        "rate": out.rate,
        "channels": list(out.layout.channel_names),
        "duration_s": out.duration,
        "time_mapping": out.meta.get("time_mapping"),
        **_figures_of_audio(np.asarray(out.audio, dtype=np.float64), out.rate, st["windows"]),
    }
    if image is not None and st["screenshot"]:
        from auralize.scene.pictures import screenshot

        busiest = int(np.argmax([sum(c.values()) for c in counts])) if counts else 0
        w, h = (int(v) for v in st["screenshot_size"])
        screenshot(
            vol,
            image,
            series=series,
            step=busiest,
            path=path,
            window_size=(w, h),
            title=f"step {busiest}",
        )
        figures["image_step"] = busiest
    return figures, _path_rows(path)


def _image_file(expect: Path) -> Path:
    return expect.with_suffix(".png")


def record(
    data: str | Path,
    expect: str | Path,
    *,
    path: Any = None,
    tolerances: dict[str, float] | None = None,
    **settings: Any,
) -> dict[str, Any]:
    """Run ``data`` with ``settings`` and store the figures in ``expect`` (JSON), the
    picture beside it (``expect`` with ``.png``), both written atomically.

    Parameters
    ----------
    data : str or Path
        The data (a file, or ``dataset:NAME``).
    expect : str or Path
        The expectation file to write (``.json``).
    path : ListenerPath, optional
        The listener path (else ``listener=(x, y, z)``, else the default orbit).
    tolerances : dict, optional
        Tolerances stored with the figures (over :data:`DEFAULT_TOLERANCES`).
    **settings
        :data:`DEFAULT_SETTINGS` to change: the reader's options (``size``,
        ``fields`` ...), ``mapping``, ``thresholds``, ``listener``, ``duration``,
        ``layout``, ``rate``, ``time_scale``, ``heard``, ``timbre``,
        ``highpass_hz``, ``windows``, ``screenshot`` (False: no picture) ...

    Returns
    -------
    dict, what was written.
    """
    from auralize.runtime.files import atomic_write, check_output_path

    expect = Path(expect)
    if expect.suffix.lower() != ".json":
        raise ParameterError(f"{expect}: an expectation file ends in .json")
    check_output_path(expect)
    st = settings_from(**settings)
    tol = tolerances_from(tolerances)
    image = _image_file(expect) if st["screenshot"] else None
    figures, used = compute(data, st, path=path, image=image)
    doc = {
        "format": FORMAT,
        "version": VERSION,
        "auralize": __version__,
        "data": str(data),
        "settings": st,
        "path": used,
        "tolerances": tol,
        "image": image.name if image is not None else None,
        "figures": figures,
    }
    atomic_write(expect, (json.dumps(doc, indent=1, allow_nan=False) + "\n").encode())
    return doc


def load_expectation(expect: str | Path) -> dict[str, Any]:
    """Read an expectation file (checked to be one)."""
    p = Path(expect)
    if not p.is_file():
        raise MissingFileError(
            f"{p}: no such expectation file (make one with 'auralize regress "
            f"record DATA -o {p.name}')"
        )
    try:
        doc = json.loads(p.read_text())
    except (ValueError, UnicodeDecodeError) as exc:
        raise FormatError(f"{p}: not a JSON expectation file ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise FormatError(f'{p}: not an auralize regression expectation (no "format": "{FORMAT}")')
    if doc.get("version") != VERSION:
        raise FormatError(
            f"{p}: expectation version {doc.get('version')!r}; this auralize "
            f"reads version {VERSION}"
        )
    return doc


def _f(v: Any, silent: float = -math.inf) -> float:
    """A stored figure as a float (null: silence, ``silent``)."""
    return silent if v is None else float(v)


def _window_name(k: int, span: list[float]) -> str:
    return f"window {k} ({span[0]:.3g}–{span[1]:.3g} s)"


def compare(
    got: dict[str, Any],
    expected: dict[str, Any],
    tol: dict[str, float],
    *,
    image_got: Path | None = None,
    image_expected: Path | None = None,
) -> list[Moved]:
    """Every figure of ``got`` beyond its tolerance of ``expected`` (see the module docstring)."""
    moved = count_changes(
        got["counts"], expected["counts"], rel=tol["counts"], at_least=int(tol["counts_at_least"])
    )
    for which in ("onset", "end"):
        for kind in TYPES:
            m = step_change(
                f"{which} {kind}",
                got[which].get(kind),
                expected[which].get(kind),
                tol=int(tol["onset"]),
                group="onset",
            )
            if m is not None:
                moved.append(m)
    if len(got["level_db"]) != len(expected["level_db"]):
        moved.append(
            Moved(
                "level",
                "level windows",
                len(got["level_db"]),
                len(expected["level_db"]),
                "a different render length",
                "the same windows",
            )
        )
        return moved
    lv_e = np.array([_f(v) for v in expected["level_db"]])
    loudest = float(np.max(lv_e)) if lv_e.size else -math.inf
    for k, (g, e) in enumerate(zip(got["level_db"], expected["level_db"], strict=True)):
        name = _window_name(k, expected["windows_s"][k])
        g, e = _f(g), _f(e)
        m = db_change(f"level {name}", g, e, tol_db=tol["level"])
        if m is not None and max(g, e) > loudest - QUIET_DB:  # not two kinds of near-silence
            moved.append(m)
        if not e > loudest - QUIET_DB:
            continue  # a quiet window: its spectrum is noise
        m = relative_change(
            "centroid",
            f"centroid {name}",
            _f(got["centroid_hz"][k], math.nan),
            _f(expected["centroid_hz"][k], math.nan),
            rtol=tol["centroid"],
            unit="Hz",
        )
        if m is not None:
            moved.append(m)
        be = np.array([_f(v) for v in expected["band_levels_db"][k]])
        bg = np.array([_f(v) for v in got["band_levels_db"][k]])
        if be.size != bg.size:
            moved.append(
                Moved("bands", f"bands {name}", bg.size, be.size, "other bands", "the same bands")
            )
            continue
        top = float(np.max(be)) if be.size else -math.inf
        for i in np.flatnonzero(be > top - QUIET_DB):
            m = db_change(
                f"band {expected['band_labels'][i]} Hz {name}",
                bg[i],
                be[i],
                tol_db=tol["bands"],
                group="bands",
            )
            if m is not None:
                moved.append(m)
    if image_expected is not None:
        if image_got is None or not image_got.is_file() or not image_expected.is_file():
            moved.append(
                Moved(
                    "image",
                    "image",
                    "missing" if image_got is None else str(image_got),
                    str(image_expected),
                    "no picture to compare",
                    "—",
                )
            )
        else:
            rms = image_rms(image_got, image_expected)
            if not rms <= tol["image"]:
                moved.append(
                    Moved(
                        "image",
                        "image (RMS pixel difference)",
                        rms,
                        0.0,
                        f"{rms:.3g} levels of 255",
                        f"{tol['image']:g}",
                    )
                )
    return moved


@dataclass
class CheckResult:
    """What :func:`check` found: ``moved`` figures (empty: passed), the figures ``got``
    and ``expected``, the tolerances used and the pictures compared."""

    moved: list[Moved]
    got: dict[str, Any]
    expected: dict[str, Any]
    tolerances: dict[str, float]
    data: str
    expect_file: Path
    image_got: Path | None = None
    image_expected: Path | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return not self.moved

    def summary(self, *, most: int = SUMMARY_LINES) -> str:
        """What moved: one line per kind of figure (how many, the first one), then the
        moved figures themselves, at most ``most`` of them (or that none moved)."""
        if self.passed:
            return f"{self.data}: ok, every figure within tolerance of {self.expect_file.name}"
        order = {g: i for i, g in enumerate(GROUPS)}
        moved = sorted(self.moved, key=lambda m: order.get(m.group, len(order)))
        groups = list(dict.fromkeys(m.group for m in moved))
        lines = [
            f"{self.data}: {len(moved)} figure(s) moved beyond tolerance of "
            f"{self.expect_file.name}: {', '.join(groups)}"
        ]
        for g in groups:
            mine = [m for m in moved if m.group == g]
            lines.append(
                f"  {g}: {len(mine)} moved, first {mine[0].figure} by {mine[0].by} "
                f"(tolerance {mine[0].tolerance})"
            )
        lines.append("  the figures:")
        lines += [f"    {m}" for m in moved[:most]]
        if len(moved) > most:
            lines.append(
                f"    ... and {len(moved) - most} more (--json or --report lists them all)"
            )
        return "\n".join(lines)


def check(
    data: str | Path,
    expect: str | Path,
    *,
    tolerances: dict[str, float] | None = None,
    report: str | Path | None = None,
) -> CheckResult:
    """Run ``data`` again with the settings and path stored in ``expect`` and compare.

    Parameters
    ----------
    data : str or Path
        The data to check (the stored ``data`` is where it was recorded; it may
        have moved since).
    expect : str or Path
        The expectation file (:func:`record`).
    tolerances : dict, optional
        Over the stored tolerances.
    report : str or Path, optional
        A folder (made if missing; its parent must exist) to write the report
        into (:func:`auralize.regression.report.write_report`): markdown and
        HTML, plots, the pictures compared.

    Returns
    -------
    CheckResult
    """
    import tempfile

    expect = Path(expect)
    doc = load_expectation(expect)
    tol = tolerances_from(doc.get("tolerances"), **(tolerances or {}))
    st = settings_from(**doc["settings"])
    path = _path_from(doc["path"])
    image_expected = expect.parent / doc["image"] if doc.get("image") else None
    if image_expected is not None and not image_expected.is_file():
        raise MissingFileError(
            f"{image_expected}: the picture recorded beside {expect.name} is "
            f"missing (record again, or keep the .png with the .json)"
        )
    folder = None
    if report is not None:
        from auralize.regression.report import report_folder

        folder = report_folder(report)
    with tempfile.TemporaryDirectory(prefix="auralize-regress-") as tmp:
        where = folder if folder is not None else Path(tmp)
        image_got = where / "got.png" if image_expected is not None else None
        got, _ = compute(data, st, path=path, image=image_got)
        moved = compare(
            got, doc["figures"], tol, image_got=image_got, image_expected=image_expected
        )
        result = CheckResult(
            moved=moved,
            got=got,
            expected=doc["figures"],
            tolerances=tol,
            data=str(data),
            expect_file=expect,
            image_got=image_got,
            image_expected=image_expected,
        )
        if folder is not None:
            from auralize.regression.report import write_report

            write_report(result, folder)
    return result
