"""VTK speaks through auralize: its messages become lines of auralize's log.

VTK's readers report problems three ways: VTK's logger (coloured lines with a
timestamp on stderr), the output window (``ERROR: In file.cxx, line N ...``,
which pyvista's reader observers echo through Python's root logger as
``ERROR:root:...``), and, for C libraries inside VTK (Exodus, CGNS), plain
prints to the process's stderr.  On the command line the user's stderr should
hold auralize's own one line, so :func:`enable` (called by
:func:`auralize.cli.console.setup_console`) routes all three into the
``auralize.vtk`` logger at debug level: one line each, no colour codes, shown
with ``-v``.  ``import auralize`` changes nothing: a script's VTK speaks as VTK
does unless it calls :func:`enable`.

The first VTK error of a read is kept (:func:`first_error`), so a reader that
fails can say why in its own message.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import sys
import tempfile
from collections.abc import Iterator
from typing import Any

LOGGER = "auralize.vtk"
_ANSI = re.compile(r"\x1b\[[0-9;]*m")
#: VTK's "ERROR: In <file>, line <n>\n<class> (<address>): " prefix of output-window text
_PREFIX = re.compile(
    r"^\s*(?:(?:ERROR|Warning|WARNING|Generic Warning):\s*In\s.+?,\s*line\s*\d+"
    r"\s*)?(?:\w*\s*\((?:0x[0-9a-fA-F]+|nullptr)\):\s*)?",
    re.DOTALL,
)

_state: dict[str, Any] = {"enabled": False, "routed": False, "errors": [], "root": None}


def one_line(text: str) -> str:
    """VTK's message as one plain line: no colour codes, no source-file prefix.

    >>> one_line("ERROR: In x.cxx, line 9\\nvtkXMLReader (0x55): Error parsing input file.\\n")
    'Error parsing input file.'
    """
    text = _PREFIX.sub("", _ANSI.sub("", text))
    text = re.sub(r"\s*\((?:0x[0-9a-fA-F]+|nullptr)\)", "", text)  # object addresses
    return " ".join(text.split())


def _log(kind: str, text: str) -> None:
    line = one_line(text)
    if not line:
        return
    if kind == "error":
        _state["errors"].append(line)
        del _state["errors"][:-20]
    logging.getLogger(LOGGER).debug("VTK %s: %s", kind, line)


class _FromRoot(logging.Handler):
    """Root-logger records (pyvista's echo of VTK's messages) into :data:`LOGGER`."""

    def emit(self, record: logging.LogRecord) -> None:
        if record.name == "root":
            _log("error" if record.levelno >= logging.ERROR else "warning", record.getMessage())


def enable() -> None:
    """Route VTK's messages into the ``auralize.vtk`` log from now on (idempotent).

    VTK itself is set up now if it is loaded, else when a reader first loads it
    (:func:`route_if_enabled`).
    """
    _state["enabled"] = True
    if _state["root"] is None:
        handler = _FromRoot()
        logging.getLogger().addHandler(handler)
        _state["root"] = handler
    if "vtkmodules.vtkCommonCore" in sys.modules:
        route_if_enabled()


def disable() -> None:
    """Stop forwarding root-logger records (VTK's own settings stay quiet)."""
    _state["enabled"] = False
    if _state["root"] is not None:
        logging.getLogger().removeHandler(_state["root"])
        _state["root"] = None


def route_if_enabled() -> None:
    """Silence VTK's logger on stderr and observe its output window, once, if enabled."""
    if not _state["enabled"] or _state["routed"]:
        return
    from vtkmodules.util.misc import calldata_type
    from vtkmodules.util.vtkConstants import VTK_STRING
    from vtkmodules.vtkCommonCore import (
        vtkCommand,
        vtkLogger,
        vtkOutputWindow,
        vtkStringOutputWindow,
    )

    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)
    window = vtkStringOutputWindow()  # keeps text instead of printing it
    vtkOutputWindow.SetInstance(window)

    def observer(kind: str) -> Any:
        @calldata_type(VTK_STRING)
        def on_event(_obj: Any, _event: str, text: Any = None) -> None:
            if text:
                _log(kind, str(text))

        return on_event

    for event, kind in (
        (vtkCommand.ErrorEvent, "error"),
        (vtkCommand.WarningEvent, "warning"),
        (vtkCommand.MessageEvent, "message"),
    ):
        window.AddObserver(event, observer(kind))
    _state["window"] = window
    _state["routed"] = True


def error_mark() -> int:
    """A mark for :func:`first_error`: the number of VTK errors logged so far."""
    return len(_state["errors"])


#: pipeline errors that follow a reader's own and say nothing about the file
_GENERIC = ("No update piece number", "returned failure for request")


def first_error(mark: int = 0) -> str | None:
    """The first VTK error logged since ``mark``, a reader's own before the pipeline's
    (None if none, or when not routed)."""
    errors = _state["errors"][mark:]
    own = [e for e in errors if not any(g in e for g in _GENERIC)]
    return (own or errors or [None])[0]


@contextlib.contextmanager
def c_stderr_logged() -> Iterator[None]:
    """While enabled, what C code prints on the process's stderr goes to the log instead.

    For libraries inside VTK that print directly (Exodus); a no-op when not enabled.
    """
    if not _state["enabled"]:
        yield
        return
    sys.stderr.flush()
    saved = os.dup(2)
    # Python's own writes (auralize's log, shown with -v) keep going to the terminal
    python_err = sys.stderr
    try:
        on_fd2 = python_err.fileno() == 2
    except (AttributeError, OSError, ValueError):  # replaced by a test or a notebook
        on_fd2 = False
    with tempfile.TemporaryFile(mode="w+b") as sink:
        os.dup2(sink.fileno(), 2)
        if on_fd2:
            sys.stderr = open(os.dup(saved), "w", buffering=1, closefd=True)
        try:
            yield
        finally:
            if on_fd2:
                sys.stderr.close()
                sys.stderr = python_err
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            text = sink.read(1 << 16).decode("utf-8", "replace")
            for block in re.split(r"\n\s*\n", text):
                if block.strip():
                    _log("error" if "ERROR" in block.upper() else "message", block)
