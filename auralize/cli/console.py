"""What the ``auralize`` command prints besides its results: log messages, warnings, bars.

:func:`setup_console` is called by the command's ``main`` only (``import
auralize`` installs nothing): messages of the ``auralize`` logger go to stderr
as ``auralize: message``; Python warnings are shown as one line
``auralize: warning: Category: message`` through the same logger (no source
file and line); ``-q`` shows errors only (no warnings, no compile notice, no
progress bars), ``-v`` adds debug messages.  It returns a function that puts
the logger, ``warnings.showwarning`` and the bar switch back as they were, for
callers that run the command inside a longer-lived process (tests, notebooks).
"""

from __future__ import annotations

import logging
import sys
import warnings
from collections.abc import Callable
from typing import Any, TextIO

LOGGER = "auralize"


class _Handler(logging.StreamHandler):
    """stderr as it is when a message is emitted (tests and notebooks swap it)."""

    def __init__(self) -> None:
        super().__init__(sys.stderr)

    @property
    def stream(self) -> TextIO:
        return sys.stderr

    @stream.setter
    def stream(self, value: Any) -> None:  # the base class assigns it; stderr wins
        pass


def _show_warning(  # noqa: PLR0917 (the signature of warnings.showwarning)
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: Any = None,
    line: str | None = None,
) -> None:
    logging.getLogger(LOGGER).warning("warning: %s: %s", category.__name__, message)


def setup_console(*, quiet: bool = False, verbose: int = 0) -> Callable[[], None]:
    """Route the ``auralize`` logger and Python warnings to stderr at the chosen verbosity.

    Parameters
    ----------
    quiet : bool
        Errors only: hides warnings, the compile notice and progress bars.
    verbose : int
        0: info and warnings; 1 or more: also debug messages.

    Returns
    -------
    restore : callable
        ``restore()`` undoes this call: the ``auralize`` logger's handlers,
        level and propagation, ``warnings.showwarning`` and the progress-bar
        switch are set back to what they were before it.
    """
    from auralize.runtime import progress, vtklog

    log = logging.getLogger(LOGGER)
    before = (
        list(log.handlers),
        log.level,
        log.propagate,
        warnings.showwarning,
        progress.is_enabled(),
    )

    def restore() -> None:
        vtklog.disable()
        handlers, level, propagate, show, bars = before
        log.handlers[:] = handlers
        log.setLevel(level)
        log.propagate = propagate
        warnings.showwarning = show
        progress.set_enabled(bars)

    for h in [h for h in log.handlers if isinstance(h, _Handler)]:
        log.removeHandler(h)
    handler = _Handler()
    handler.setFormatter(logging.Formatter("auralize: %(message)s"))
    log.addHandler(handler)
    log.propagate = False
    log.setLevel(logging.ERROR if quiet else logging.DEBUG if verbose else logging.INFO)
    warnings.showwarning = _show_warning
    progress.set_enabled(not quiet)
    vtklog.enable()  # VTK's messages: one line each in this log, shown with -v
    return restore
