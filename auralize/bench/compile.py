"""``auralize bench`` rows of the cold compile: what a new user (or a CI run) waits for
before the first sound.

Each row runs a fresh ``auralize`` process against an empty kernel cache (a
temporary ``NUMBA_CACHE_DIR``), so the figures are the machine's, taken as a
user meets them: ``auralize warmup`` (the install step), and the first
``auralize demo`` without a warm-up; the demo's compile notices are compared
with what the kernels they announce took.  Minutes of CPU: the full bench only.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from typing import Any

from auralize.plugins import BenchRow

#: the cold warm-up's target, wall seconds on the 2-core reference machine
WARMUP_TARGET_S = 60.0
#: the first demo's target, wall seconds (no warm-up before it)
DEMO_TARGET_S = 90.0
#: how far the compile notice's estimate may be from the compile it announces
ESTIMATE_TOLERANCE = 0.5

#: the child of :func:`_first_demo`: the demo, then what was announced and compiled
_DEMO_CHILD = """
import json, sys
from auralize.cli.core import main
from auralize.runtime.jit import compile_notices, compile_waits, compiled_kernels
status = main(["-q", "demo", "-o", sys.argv[1]])
print("AURALIZE-COMPILE " + json.dumps({"status": status, "notices": compile_notices(),
                                       "compiled": compiled_kernels(), "waits": compile_waits()}))
"""


def _run_cold(args: list[str], cache: str) -> tuple[float, float, str]:
    """Run ``python args`` with the kernel cache ``cache``: wall seconds, CPU seconds
    (the process and its children) and its standard output."""
    env = {**os.environ, "NUMBA_CACHE_DIR": cache}
    env.pop("AURALIZE_CACHE_DIR", None)
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run(
        [sys.executable, *args], env=env, capture_output=True, text=True, check=True
    )
    wall = time.perf_counter() - t0
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime)
    return wall, cpu, res.stdout


def _cold_warmup() -> list[BenchRow]:
    with tempfile.TemporaryDirectory(prefix="auralize-bench-numba-") as cache:
        wall, cpu, out = _run_cold(["-m", "auralize", "warmup", "--json"], cache)
    res = json.loads(out[out.index("{") :])
    groups = ", ".join(f"{g['group']} {g['cpu_seconds']:.0f}" for g in res["groups"])
    dearest = sorted(res["compiled"], key=lambda c: -c[1])[:3]
    return [
        BenchRow(
            "compile",
            "cold auralize warmup (empty cache)",
            wall,
            "s",
            target=f"≤ {WARMUP_TARGET_S:g} s",
            met=wall <= WARMUP_TARGET_S,
            note=f"{cpu:.0f} CPU-s in {res['processes']} processes (groups, CPU-s: {groups}); "
            "dearest kernels (CPU-s): "
            + ", ".join(
                f"{n.rsplit('.', 2)[-2]}.{n.rsplit('.', 1)[-1]} {s:.0f}" for n, s in dearest
            ),
        )
    ]


def _estimate_error(
    notices: list[list[Any]], compiled: list[list[Any]], waits: list[list[Any]] | None = None
) -> tuple[float, str]:
    """The largest relative error of the compile notices' estimates against what they
    announced: a kernel the command waited for while another process compiled it
    against the wait (wall seconds), a kernel announced alone (its own estimate at least
    :data:`auralize.runtime.jit.NOTICE_AGAIN_SECONDS`) against its own compile, the
    first notice (a module's cheap kernels) against that module's kernels but those
    announced on their own."""
    from auralize.runtime.jit import DEFAULT_SECONDS, NOTICE_AGAIN_SECONDS, compile_seconds

    waited = {str(n): float(s) for n, s in waits or []}
    # (as the notice decides: a kernel of its own estimate >= NOTICE_AGAIN_SECONDS alone)
    alone = {
        str(n)
        for n, _ in notices
        if compile_seconds().get(str(n), DEFAULT_SECONDS) >= NOTICE_AGAIN_SECONDS
    }
    worst, what = 0.0, ""
    for name, est in notices:
        if name in waited:
            took = waited[name]
        elif name in alone:
            took = sum(s for n, s in compiled if n == name)
        else:  # the module's kernels, but those announced on their own
            module = name.rsplit(".", 1)[0]
            took = sum(s for n, s in compiled if n.rsplit(".", 1)[0] == module and n not in alone)
        if took <= 0.0:
            continue
        err = est / took - 1.0
        if abs(err) >= abs(worst):
            worst, what = (
                err,
                f"{name.rsplit('.', 2)[-2]}.{name.rsplit('.', 1)[-1]}: ~{est:.0f} s "
                f"announced, {took:.0f} {'s waited' if name in waited else 'CPU-s'}",
            )
    return worst, what


def _first_demo() -> list[BenchRow]:
    with (
        tempfile.TemporaryDirectory(prefix="auralize-bench-numba-") as cache,
        tempfile.TemporaryDirectory(prefix="auralize-bench-demo-") as out_dir,
    ):
        wall, cpu, out = _run_cold(["-c", _DEMO_CHILD, out_dir], cache)
    line = next(x for x in out.splitlines() if x.startswith("AURALIZE-COMPILE "))
    res = json.loads(line.split(" ", 1)[1])
    compiled = res["compiled"]
    err, what = _estimate_error(res["notices"], compiled, res.get("waits"))
    total = sum(s for _, s in compiled)
    return [
        BenchRow(
            "compile",
            "first auralize demo (empty cache, no warm-up)",
            wall,
            "s",
            target=f"≤ {DEMO_TARGET_S:g} s",
            met=wall <= DEMO_TARGET_S,
            note=f"{cpu:.0f} CPU-s in all, {total:.0f} CPU-s compiling {len(compiled)} kernels",
        ),
        BenchRow(
            "compile",
            "compile notice: estimate vs compile (worst)",
            100.0 * err,
            "%",
            target=f"within ±{100 * ESTIMATE_TOLERANCE:.0f} %",
            met=abs(err) <= ESTIMATE_TOLERANCE,
            note=f"{len(res['notices'])} notices in the demo; worst {what}",
        ),
    ]


def compile_rows(quick: bool) -> list[BenchRow]:
    """The cold warm-up and the first demo, each from an empty cache (minutes: not with
    ``--quick``)."""
    if quick:
        return []
    return _cold_warmup() + _first_demo()
