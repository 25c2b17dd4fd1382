"""-q/-v, one-line warnings, progress bars (tqdm.auto) and the kernel-compile notice."""

from __future__ import annotations

import io
import logging
import warnings

import numba
import pytest
from numba.core import event

from auralize.cli import build_parser, console
from auralize.cli.console import setup_console
from auralize.runtime import jit as _numba_setup
from auralize.runtime import progress


@pytest.fixture(autouse=True)
def _restore() -> None:  # type: ignore[misc]
    # each test starts from the state of a fresh process, whatever ran before it
    # (``auralize.cli.main`` sets the console up), and leaves it as it found it
    log = logging.getLogger("auralize")
    handlers, level, prop = list(log.handlers), log.level, log.propagate
    show, bars = warnings.showwarning, progress.is_enabled()
    log.handlers[:] = [h for h in handlers if not isinstance(h, console._Handler)]
    log.setLevel(logging.NOTSET)
    log.propagate = True
    progress.set_enabled(True)
    yield
    log.handlers[:] = handlers
    log.setLevel(level)
    log.propagate = prop
    warnings.showwarning = show
    progress.set_enabled(bars)


def test_verbosity_flags_before_or_after_the_command() -> None:
    ap = build_parser()
    assert ap.parse_args(["-q", "plugins"]).quiet is True
    a = ap.parse_args(["plugins", "-q"])
    assert a.quiet is True and a.verbose == 0
    assert ap.parse_args(["-vv", "plugins"]).verbose == 2
    assert ap.parse_args(["plugins", "-vv"]).verbose == 2
    a = ap.parse_args(
        ["spark", "render", "-o", "x.wav", "--listener", "0,0,1", "--duration", "0.1", "-q"]
    )
    assert a.quiet is True
    assert ap.parse_args(["plugins"]).quiet is False


def test_warnings_are_one_line_and_quiet_hides_them(capsys) -> None:  # type: ignore[no-untyped-def]
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        setup_console()
        warnings.warn("grid resampled", UserWarning, stacklevel=1)
        err = capsys.readouterr().err
        assert err == "auralize: warning: UserWarning: grid resampled\n"
        setup_console(quiet=True)
        warnings.warn("grid resampled", UserWarning, stacklevel=1)
        assert capsys.readouterr().err == ""
        assert not progress.visible()


def test_setup_console_can_put_the_process_back() -> None:
    log = logging.getLogger("auralize")
    show = warnings.showwarning
    restore = setup_console(quiet=True)
    assert log.propagate is False and log.level == logging.ERROR
    assert warnings.showwarning is not show and not progress.is_enabled()
    restore()
    assert log.propagate is True and log.level == logging.NOTSET
    assert not [h for h in log.handlers if isinstance(h, console._Handler)]
    assert warnings.showwarning is show and progress.is_enabled()


def test_progress_bars_show_on_a_terminal_or_in_jupyter(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    out = io.StringIO()
    monkeypatch.setattr(progress.sys, "stderr", out)
    assert not progress.visible()  # not a terminal, no Jupyter kernel
    assert list(progress.progress(range(3), desc="detect")) == [0, 1, 2]
    assert out.getvalue() == ""
    monkeypatch.setattr(out, "isatty", lambda: True, raising=False)
    assert progress.visible()
    assert list(progress.progress(range(3), desc="peak pass", total=3)) == [0, 1, 2]
    assert "peak pass" in out.getvalue()
    with progress.progress_step("render", interval_s=0.01):
        pass
    assert "render" in out.getvalue()
    progress.set_enabled(False)
    assert not progress.visible()


def test_compile_notice_names_an_estimate_once(caplog, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setattr(_numba_setup._NOTICE, "announced", True)  # the process-wide one
    notice = _numba_setup._CompileNotice()
    event.register("numba:compile", notice)
    try:

        def twice(x):  # type: ignore[no-untyped-def]
            return 2 * x

        twice.__module__ = "auralize._test_kernel"
        twice.__qualname__ = "twice"
        k = numba.njit(twice)
        with caplog.at_level(logging.WARNING, logger="auralize"):
            assert k(2) == 4 and k(2.5) == 5.0  # two specializations, one notice
    finally:
        event.unregister("numba:compile", notice)
    msgs = [r.getMessage() for r in caplog.records if "compiling kernels" in r.getMessage()]
    assert len(msgs) == 1 and msgs[0].startswith("compiling kernels, once: ~")
    assert [n for n, _ in notice.compiled] == ["auralize._test_kernel.twice"] * 2


def test_progress_callback_drives_a_bar_or_logs(monkeypatch, caplog) -> None:  # type: ignore[no-untyped-def]
    out = io.StringIO()
    monkeypatch.setattr(progress.sys, "stderr", out)
    with (
        caplog.at_level(logging.INFO, logger="auralize"),
        progress.progress_callback("texture", total=2) as cb,
    ):
        cb("u = 1 m/s")
    assert [r.getMessage() for r in caplog.records] == ["texture: u = 1 m/s"]
    monkeypatch.setattr(out, "isatty", lambda: True, raising=False)
    with progress.progress_callback("texture", unit="direction") as cb:
        cb(1, 4)
        cb(4, 4)
    assert "texture" in out.getvalue() and "4/4" in out.getvalue()


def test_jupyter_without_ipywidgets_gets_the_text_bar_and_no_warning(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    import sys
    import types

    import tqdm.notebook
    import tqdm.std

    class ZMQInteractiveShell:  # the name Jupyter's kernel shell has
        pass

    fake = types.ModuleType("IPython")
    fake.get_ipython = ZMQInteractiveShell  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "IPython", fake)
    real_find_spec = progress.importlib.util.find_spec

    def no_widgets(name: str, *a: object) -> object:
        return None if name == "ipywidgets" else real_find_spec(name, *a)  # type: ignore[arg-type]

    monkeypatch.setattr(progress.importlib.util, "find_spec", no_widgets)
    out = io.StringIO()
    monkeypatch.setattr(progress.sys, "stderr", out)
    assert progress.visible() and progress._bar_class() is tqdm.std.tqdm
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # tqdm.auto's TqdmWarning would raise here
        assert list(progress.progress(range(3), desc="detect", total=3)) == [0, 1, 2]
    assert "detect" in out.getvalue()
    monkeypatch.setattr(progress.importlib.util, "find_spec", lambda name, *a: object())
    assert progress._bar_class() is tqdm.notebook.tqdm
