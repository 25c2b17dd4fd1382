"""``auralize bench``'s compile rows: how the compile notice is held against the compile
it announced, and the cold runs' measurement (the rows themselves take minutes: the
full bench only)."""

from __future__ import annotations

import pytest

from auralize.bench.compile import _estimate_error, _run_cold, compile_rows
from auralize.runtime.jit import NOTICE_AGAIN_SECONDS

PIECES = "auralize.emitters._kernels.render_pieces.render_task"
DETECT = "auralize.sources._kernels.residual"


def test_a_kernel_announced_alone_is_held_against_its_own_compile() -> None:
    big = 4.0 * NOTICE_AGAIN_SECONDS
    compiled = [[PIECES, 0.5 * big], ["auralize.emitters._kernels.tables.fill_runs", 5.0]]
    err, what = _estimate_error([[PIECES, big]], compiled)
    assert err == pytest.approx(1.0)  # announced twice what it took
    assert "render_task" in what


def test_the_first_notice_is_held_against_its_module(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """The first notice estimates the cheap kernels of its module together."""
    from auralize.runtime import jit

    compiled = [[DETECT, 3.0], ["auralize.sources._kernels.gradient", 1.0], [PIECES, 50.0]]
    err, _ = _estimate_error([[DETECT, 3.0]], compiled)
    assert err == pytest.approx(3.0 / 4.0 - 1.0)
    assert _estimate_error([], compiled) == (0.0, "")
    # a kernel of the module announced on its own is not in the first notice's figure
    dear = "auralize.sources._kernels._dear"
    big = 2.0 * NOTICE_AGAIN_SECONDS
    monkeypatch.setitem(jit.compile_seconds(), dear, big)
    err, _ = _estimate_error([[DETECT, 4.0], [dear, big]], [*compiled, [dear, big]])
    assert err == pytest.approx(0.0)


def test_cold_runs_measure_wall_and_cpu_with_their_own_cache(tmp_path) -> None:  # type: ignore[no-untyped-def]
    code = "import os, time; t = time.process_time()\nwhile time.process_time() - t < 0.2: pass\n"
    code += "print(os.environ['NUMBA_CACHE_DIR'])"
    wall, cpu, out = _run_cold(["-c", code], str(tmp_path))
    assert out.strip() == str(tmp_path)
    assert cpu >= 0.2 and wall >= 0.2


def test_quick_bench_skips_the_cold_compiles() -> None:
    assert compile_rows(True) == []


def test_a_kernel_waited_for_is_held_against_the_wait() -> None:
    """A kernel compiled by a background process is announced when the command waits for
    it; the notice is held against the wait, not against a compile in this process."""
    err, what = _estimate_error([[PIECES, 30.0]], [], [[PIECES, 20.0]])
    assert err == pytest.approx(0.5)
    assert "waited" in what
