"""Progress bars for long work: ``tqdm.auto`` (a widget in Jupyter, text on a terminal).

Bars show when they can be seen: stderr is a terminal, or the code runs in a
Jupyter kernel.  ``auralize -q`` turns them off (:func:`set_enabled`).
"""

from __future__ import annotations

import contextlib
import importlib.util
import logging
import sys
import threading
from collections.abc import Callable, Iterable, Iterator
from typing import Any, TypeVar

T = TypeVar("T")

_enabled = True


def set_enabled(enabled: bool) -> None:
    """Allow (True) or suppress (False) every progress bar of this process."""
    global _enabled
    _enabled = bool(enabled)


def is_enabled() -> bool:
    """False after ``set_enabled(False)`` (``auralize -q``): no bar will show."""
    return _enabled


def _in_jupyter_kernel() -> bool:
    """True inside a running Jupyter kernel (not merely with ipykernel imported)."""
    ipython = sys.modules.get("IPython")
    if ipython is None:
        return False
    shell = getattr(ipython, "get_ipython", lambda: None)()
    return type(shell).__name__ == "ZMQInteractiveShell"


def visible() -> bool:
    """True when a bar would be seen: bars allowed and a terminal or a Jupyter kernel."""
    if not _enabled:
        return False
    if _in_jupyter_kernel():
        return True
    err = sys.stderr
    return bool(err is not None and hasattr(err, "isatty") and err.isatty())


def _bar_class() -> Any:
    """tqdm's widget bar inside Jupyter when ipywidgets is installed, else its text bar.

    ``tqdm.auto`` alone warns in red (``IProgress not found``) in a notebook
    without ipywidgets; the text bar prints cleanly into the cell instead.
    """
    if _in_jupyter_kernel() and importlib.util.find_spec("ipywidgets") is not None:
        from tqdm.notebook import tqdm as widget_bar

        return widget_bar
    from tqdm.std import tqdm as text_bar

    return text_bar


def _bar(**kw: Any) -> Any:
    tqdm = _bar_class()
    return tqdm(leave=False, file=sys.stderr, dynamic_ncols=True, **kw)


def progress(
    it: Iterable[T], *, desc: str, enabled: bool = True, total: int | None = None, unit: str = "it"
) -> Iterator[T]:
    """Wrap ``it`` in a bar when ``enabled`` and :func:`visible`."""
    if not enabled or not visible():
        yield from it
        return
    bar = _bar(desc=desc, total=total, unit=unit)
    try:
        for x in it:
            yield x
            bar.update()
    finally:
        bar.close()


@contextlib.contextmanager
def progress_step(desc: str, *, enabled: bool = True, interval_s: float = 0.5) -> Iterator[None]:
    """A bar for one long call that reports no progress of its own: the elapsed time.

    The bar is redrawn every ``interval_s`` seconds from a helper thread while
    the ``with`` block runs, and completes when it ends.
    """
    if not enabled or not visible():
        yield
        return
    bar = _bar(desc=desc, total=1, bar_format="{desc}: {elapsed}")
    done = threading.Event()

    def tick() -> None:
        while not done.wait(interval_s):
            bar.refresh()

    th = threading.Thread(target=tick, name="auralize-progress", daemon=True)
    th.start()
    try:
        yield
        bar.update()
    finally:
        done.set()
        th.join()
        bar.close()


@contextlib.contextmanager
def progress_callback(
    desc: str, *, total: int | None = None, enabled: bool = True, unit: str = "it"
) -> Iterator[Callable[..., None]]:
    """A bar driven by a work function's own progress callback.

    Yields ``cb``: ``cb(done, total)`` sets the bar's position, ``cb(message)``
    advances it by one and shows ``message`` beside it.  Without a visible bar
    the messages go to the ``auralize`` logger at info level (one line each).
    """
    if not enabled or not visible():

        def quiet(*args: Any) -> None:
            if len(args) == 1:
                logging.getLogger("auralize").info("%s: %s", desc, args[0])

        yield quiet
        return
    bar = _bar(desc=desc, total=total, unit=unit)

    def cb(*args: Any) -> None:
        if len(args) == 2:
            bar.total = int(args[1])
            bar.n = int(args[0])
            bar.refresh()
        else:
            bar.update()
            if args:
                bar.set_postfix_str(str(args[0]), refresh=True)

    try:
        yield cb
    finally:
        bar.close()
