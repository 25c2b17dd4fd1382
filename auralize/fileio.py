"""Atomic file output: write to a temporary file beside the target, then rename.

Bad input or a crash never leaves a partial output file behind.
"""

from __future__ import annotations

import contextlib
import csv
import io
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from numpy.typing import NDArray


@contextlib.contextmanager
def atomic_path(path: str | Path, *, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path in the target's folder; rename it onto ``path`` on success.

    On any exception the temporary file is removed and ``path`` is untouched.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(
        prefix=f".{target.name}.", suffix=suffix if suffix is not None else target.suffix + ".part",
        dir=target.parent,
    )  # fmt: skip
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp makes the file private (0600): give it the usual permissions
        os.chmod(tmp_path, 0o666 & ~_umask())
        os.replace(tmp_path, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        raise


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def atomic_write(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def read_timed_csv(path: str | Path, *, what: str, optional: list[str],
                   rows_name: str = "captures") -> tuple[NDArray[np.float64], bool, str]:  # fmt: skip
    """Read a numeric CSV whose header starts ``t,x,y,z`` and may go on with ``optional``.

    Returns ``(rows as a flat table (n, 4 or 4 + len(optional)), has_optional,
    source name)``; malformed files raise :class:`~auralize.errors.FormatError`
    naming the file, line and what was expected.  Used for listener paths and
    object motions.
    """
    from auralize.errors import FormatError

    p = Path(path)
    try:
        text = p.read_text()
    except FileNotFoundError:
        raise FormatError(f"{what} file {str(p)!r} does not exist") from None
    except UnicodeDecodeError:
        raise FormatError(f"{p}: not a text CSV file") from None
    reader = csv.reader(io.StringIO(text))
    want = "t,x,y,z" + "".join("," + c for c in optional)
    try:
        header = [h.strip().lower() for h in next(reader)]
    except StopIteration:
        raise FormatError(f"{p}: empty file; expected a header '{want}'") from None
    if header[:4] != ["t", "x", "y", "z"]:
        raise FormatError(
            f"{p}: header must start with 't,x,y,z' (optional {','.join(optional)}); "
            f"got {','.join(header)!r}"
        )
    has_opt = bool(optional) and header[4 : 4 + len(optional)] == optional
    ncol = 4 + (len(optional) if has_opt else 0)
    rows = []
    for lineno, row in enumerate(reader, start=2):
        if not row or all(not c.strip() for c in row):
            continue
        try:
            vals = [float(c) for c in row[:ncol]]
        except ValueError:
            raise FormatError(f"{p}, line {lineno}: not a number in {row!r}") from None
        if len(vals) != ncol:
            raise FormatError(f"{p}, line {lineno}: expected {ncol} columns, got {len(row)}")
        rows.append(vals)
    if not rows:
        raise FormatError(f"{p}: no {rows_name} after the header")
    return np.asarray(rows, dtype=np.float64), has_opt, str(p)
