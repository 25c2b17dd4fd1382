"""``auralize warmup``: compile the numba kernels once, ahead of the first real command."""

from __future__ import annotations

import argparse
import json
import time
from typing import Any


def cmd_warmup(args: argparse.Namespace) -> int:
    from auralize.runtime.jit import cache_dir
    from auralize.warmup import GROUPS, PLUGIN_GROUPS, warmup

    groups = {**GROUPS, **(PLUGIN_GROUPS if args.plugins else {})}
    print(
        f"auralize warmup: compiling the numba kernels into {cache_dir()} "
        "(minutes the first time, seconds afterwards) ...",
        flush=True,
    )
    t0 = time.perf_counter()

    def progress(res: dict[str, Any]) -> None:
        if args.json:
            return
        n = len(res["compiled"])
        what = f"{n} kernel(s) compiled" if n else "cached"
        print(
            f"  [{time.perf_counter() - t0:6.1f} s] {res['group']}: {what} in "
            f"{res['seconds']:.1f} s ({res.get('cpu_seconds', 0.0):.1f} CPU-s; "
            f"{groups[res['group']]})",
            flush=True,
        )
        for name, sec in sorted(res["compiled"], key=lambda x: -x[1]):
            if sec >= 1.0:
                print(f"      {sec:7.1f} s  {name}", flush=True)

    out = warmup(plugins=args.plugins, processes=args.processes, progress=progress)
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    n = len(out["compiled"])
    what = f"{n} kernel(s) compiled" if n else "all kernels were cached"
    print(f"kernels ready in {out['seconds']:.1f} s ({out['processes']} process(es)): {what}")
    return 0


def add_commands(sub: Any) -> None:
    p = sub.add_parser("warmup", help="compile the numba kernels now (done once by install.sh)")
    p.add_argument("--plugins", action="store_true", help="also the plugins' kernels")
    p.add_argument(
        "--processes",
        type=int,
        default=None,
        metavar="N",
        help="kernel groups compiled at once, one process each (default: 2, or 1 on one core)",
    )
    p.add_argument("--json", action="store_true", help="print what was compiled as JSON")
    p.set_defaults(func=cmd_warmup)
