"""Start-up and first-run figures of the ``auralize`` command, against the targets.

    python scripts/bench_startup.py                 # start-up + first run (minutes: compiles)
    python scripts/bench_startup.py --startup-only  # seconds
    python scripts/bench_startup.py --cold-demo     # also the demo straight from a cold cache

Start-up: ``auralize --version``, ``--help`` and ``auralize vortex render
--help``, best of 5 (target < 0.5 s).  First run: a new user's sequence after
``scripts/install.sh``, with an empty numba cache (``NUMBA_CACHE_DIR`` set to a
fresh folder): the install step ``auralize warmup`` (compiles the kernels),
then ``auralize demo`` (target < 30 s).  Each row gives wall-clock seconds and
the CPU seconds (user + system) of the process, which a loaded machine does
not inflate.  Runs the ``auralize`` next to this interpreter (or ``python -m
auralize.cli``).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _command() -> list[str]:
    exe = Path(sys.executable).with_name("auralize")
    return [str(exe)] if exe.is_file() else [sys.executable, "-m", "auralize.cli"]


def timed(args: list[str], env: dict[str, str], cwd: str) -> tuple[float, float, str]:
    """(wall s, CPU s, output) of one run of ``auralize ARGS``."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run([*_command(), *args], env=env, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode != 0:
        raise SystemExit(f"auralize {' '.join(args)} failed:\n{out.stdout}\n{out.stderr}")
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return wall, cpu, out.stdout + out.stderr


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--startup-only", action="store_true")
    ap.add_argument(
        "--cold-demo",
        action="store_true",
        help="also run the demo from an empty cache without the warm-up",
    )
    ap.add_argument("--size", type=int, default=64, help="demo grid size (default 64)")
    ap.add_argument("--json", metavar="FILE", help="also write the rows as JSON")
    args = ap.parse_args()
    env = dict(os.environ)
    rows: list[dict[str, object]] = []
    work = tempfile.mkdtemp(prefix="auralize-bench-startup-")
    try:
        for cmd in (["--version"], ["--help"], ["vortex", "render", "--help"]):
            runs = [timed(cmd, env, work)[:2] for _ in range(5)]
            rows.append(
                {
                    "what": f"auralize {' '.join(cmd)}",
                    "wall_s": min(r[0] for r in runs),
                    "cpu_s": min(r[1] for r in runs),
                    "target": "< 0.5 s",
                }
            )
        if not args.startup_only:
            env["NUMBA_CACHE_DIR"] = str(Path(work) / "numba-cache")  # empty: a cold cache
            wall, cpu, out = timed(["warmup"], env, work)
            rows.append(
                {
                    "what": "install step: auralize warmup (cold cache)",
                    "wall_s": wall,
                    "cpu_s": cpu,
                    "target": "",
                    "note": out.strip().splitlines()[-1],
                }
            )
            wall, cpu, out = timed(["demo", "-o", "demo", "--size", str(args.size)], env, work)
            rows.append(
                {
                    "what": f"first auralize demo after install ({args.size}³)",
                    "wall_s": wall,
                    "cpu_s": cpu,
                    "target": "< 30 s",
                    "note": "compiled kernels" if "compiling kernels" in out else "no compiling",
                }
            )
            if args.cold_demo:
                env["NUMBA_CACHE_DIR"] = str(Path(work) / "numba-cache-2")
                wall, cpu, out = timed(["demo", "-o", "demo2", "--size", str(args.size)], env, work)
                rows.append(
                    {
                        "what": f"auralize demo from a cold cache, no warm-up ({args.size}³)",
                        "wall_s": wall,
                        "cpu_s": cpu,
                        "target": "",
                        "note": "compiled kernels" if "compiling kernels" in out else "",
                    }
                )
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"{'what':58s} {'wall s':>8s} {'CPU s':>8s}  target")
    for r in rows:
        print(
            f"{r['what']:58s} {r['wall_s']:8.2f} {r['cpu_s']:8.2f}  {r['target']}  "
            f"{r.get('note', '')}"
        )
    print(f"({os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f})")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
