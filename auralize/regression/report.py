"""The report of a regression check (``auralize regress check --report DIR``).

:func:`write_report` writes into one folder:

* ``report.md`` and ``report.html`` — the verdict, a table of every figure that
  moved (got, expected, by how much, the tolerance), the settings and the
  plots;
* ``level.png`` (level and centroid along the path, expected and got),
  ``counts.png`` (source points per step and type), ``bands.png`` (the change
  of every ⅓-octave band in every window, dB);
* ``expected.png``, ``got.png`` and ``difference.png`` — the pictures compared
  and their absolute difference (brightened four times).

Every file is written atomically (:mod:`auralize.runtime.files`); the folder
is made if missing (its parent must exist), and files of other names in it
are left alone.
"""

from __future__ import annotations

import html
import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from auralize.errors import OutputError
from auralize.regression.compare import TYPES
from auralize.runtime.files import atomic_path, atomic_write, check_output_path

__all__ = ["REPORT_FILES", "report_folder", "write_report"]

#: the files a report is made of
REPORT_FILES = (
    "report.md",
    "report.html",
    "level.png",
    "counts.png",
    "bands.png",
    "expected.png",
    "got.png",
    "difference.png",
)


def report_folder(folder: str | Path) -> Path:
    """The report's folder, made if missing (its parent must exist, as for every output)."""
    p = check_output_path(folder, folder=True)
    p.mkdir(exist_ok=True)
    return p


def _num(v: Any) -> float:
    return math.nan if v is None else float(v)


def _figure(w: float = 7.0, h: float = 3.2, rows: int = 1) -> Any:
    from matplotlib.figure import Figure

    return Figure(figsize=(w, h * rows), layout="constrained")


def _save(fig: Any, out: Path) -> None:
    with atomic_path(out, suffix=".part.png") as tmp:
        fig.savefig(tmp, dpi=90, format="png")


def _level_plot(r: Any, out: Path) -> None:
    fig = _figure(rows=2)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for fig_of, style, label in ((r.expected, "o-", "expected"), (r.got, "x--", "got")):
        mid = [0.5 * (a + b) for a, b in fig_of["windows_s"]]
        ax1.plot(mid, [_num(v) for v in fig_of["level_db"]], style, label=label)
        ax2.plot(mid, [_num(v) for v in fig_of["centroid_hz"]], style, label=label)
    ax1.set_ylabel("level, dB re 20 µPa")
    ax1.legend()
    ax2.set_ylabel("spectral centroid, Hz")
    ax2.set_xlabel("playback time, s (window centres)")
    ax1.set_title("along the listener path")
    _save(fig, out)


def _counts_plot(r: Any, out: Path) -> None:
    fig = _figure()
    ax = fig.subplots()
    for i, k in enumerate(TYPES):
        for fig_of, style in ((r.expected, "-"), (r.got, ":")):
            ax.plot(
                [c.get(k, 0) for c in fig_of["counts"]],
                style,
                color=f"C{i}",
                label=f"{k} ({'expected' if fig_of is r.expected else 'got'})",
            )
    ax.set_xlabel("time step")
    ax.set_ylabel("source points")
    ax.legend(fontsize=7, ncol=3)
    _save(fig, out)


def _bands_plot(r: Any, out: Path) -> None:
    e = np.array([[_num(v) for v in row] for row in r.expected["band_levels_db"]], dtype=float)
    g = np.array([[_num(v) for v in row] for row in r.got["band_levels_db"]], dtype=float)
    fig = _figure()
    ax = fig.subplots()
    if e.shape == g.shape and e.size:
        with np.errstate(invalid="ignore"):
            d = np.where(np.isfinite(e) & np.isfinite(g), g - e, np.nan)
        lim = max(float(np.nanmax(np.abs(d))) if np.any(np.isfinite(d)) else 1.0, 1.0)
        im = ax.imshow(d.T, origin="lower", aspect="auto", cmap="coolwarm", vmin=-lim, vmax=lim)
        labels = r.expected["band_labels"]
        step = max(1, len(labels) // 10)
        ax.set_yticks(range(0, len(labels), step), labels[::step])
        ax.set_xlabel("window")
        ax.set_ylabel("⅓-octave band, Hz")
        fig.colorbar(im, ax=ax, label="got − expected, dB")
    else:
        ax.text(0.5, 0.5, "the bands or windows differ", ha="center", va="center")
    _save(fig, out)


def _pictures(r: Any, folder: Path) -> bool:
    """expected.png, got.png (already there) and difference.png; False if there are none."""
    from PIL import Image

    if r.image_expected is None or r.image_got is None or not r.image_got.is_file():
        return False
    with atomic_path(folder / "expected.png", suffix=".part.png") as tmp:
        shutil.copyfile(r.image_expected, tmp)
    if r.image_got.resolve() != (folder / "got.png").resolve():
        with atomic_path(folder / "got.png", suffix=".part.png") as tmp:
            shutil.copyfile(r.image_got, tmp)
    with Image.open(r.image_expected) as a, Image.open(r.image_got) as b:
        ea = np.asarray(a.convert("RGB"), dtype=np.int16)
        gb = np.asarray(b.convert("RGB"), dtype=np.int16)
    if ea.shape == gb.shape:
        diff = np.clip(4 * np.abs(ea - gb), 0, 255).astype(np.uint8)
        with atomic_path(folder / "difference.png", suffix=".part.png") as tmp:
            Image.fromarray(diff).save(tmp, format="PNG")
    return True


def _rows(r: Any) -> list[list[str]]:
    return [
        [
            m.figure,
            f"{m.got:.6g}" if isinstance(m.got, float) else str(m.got),
            f"{m.expected:.6g}" if isinstance(m.expected, float) else str(m.expected),
            m.by,
            m.tolerance,
        ]
        for m in r.moved
    ]


def write_report(result: Any, folder: str | Path) -> Path:
    """Write the report of ``result`` (a :class:`auralize.regression.user.CheckResult`)
    into ``folder``; returns the markdown file."""
    folder = report_folder(folder)
    try:
        _level_plot(result, folder / "level.png")
        _counts_plot(result, folder / "counts.png")
        _bands_plot(result, folder / "bands.png")
        pictures = _pictures(result, folder)
    except OSError as exc:
        raise OutputError(f"cannot write the report into {folder}: {exc}") from exc
    verdict = (
        "passed: every figure is within its tolerance"
        if result.passed
        else f"FAILED: {len(result.moved)} figure(s) moved beyond their tolerance"
    )
    head = ["figure", "got", "expected", "moved by", "tolerance"]
    rows = _rows(result)
    tol = ", ".join(f"{k} {v:g}" for k, v in result.tolerances.items())
    plots = [
        ("level.png", "level and spectral centroid along the path"),
        ("counts.png", "source points per step and type"),
        ("bands.png", "change of the ⅓-octave band levels per window"),
    ]
    if pictures:
        plots += [
            ("expected.png", "expected picture"),
            ("got.png", "picture now"),
            ("difference.png", "difference (×4)"),
        ]
    md = [
        f"# auralize regression check: {result.data}",
        "",
        f"Expectation: `{result.expect_file}`",
        "",
        f"**{verdict}**",
        "",
        f"Tolerances: {tol}",
        "",
    ]
    if rows:
        md += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        md += ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |" for row in rows]
        md.append("")
    md += [f"![{alt}]({name})" for name, alt in plots]
    atomic_write(folder / "report.md", ("\n".join(md) + "\n").encode("utf-8"))
    e = html.escape
    table = ""
    if rows:
        table = (
            "<table><tr>"
            + "".join(f"<th>{e(h)}</th>" for h in head)
            + "</tr>"
            + "".join("<tr>" + "".join(f"<td>{e(c)}</td>" for c in row) + "</tr>" for row in rows)
            + "</table>"
        )
    imgs = "".join(
        f'<figure><img src="{e(n)}" alt="{e(a)}"><figcaption>{e(a)}</figcaption></figure>'
        for n, a in plots
    )
    page = (
        f"<!doctype html><html lang=en><meta charset=utf-8><title>auralize regression "
        f"check: {e(result.data)}</title><style>body{{font-family:sans-serif;margin:2em}}"
        f"td,th{{border:1px solid #ccc;padding:.2em .5em}}table{{border-collapse:collapse}}"
        f"img{{max-width:100%}}</style><h1>auralize regression check: {e(result.data)}</h1>"
        f"<p>Expectation: <code>{e(str(result.expect_file))}</code></p><p><strong>"
        f"{e(verdict)}</strong></p><p>Tolerances: {e(tol)}</p>{table}{imgs}</html>\n"
    )
    atomic_write(folder / "report.html", page.encode("utf-8"))
    return folder / "report.md"
