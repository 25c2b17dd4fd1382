"""``auralize warmup``: compile the numba kernels once, ahead of the first real command."""

from __future__ import annotations

import argparse
import json
from typing import Any


def cmd_warmup(args: argparse.Namespace) -> int:
    from auralize.runtime.jit import cache_dir
    from auralize.runtime.warmup import warmup

    print(f"auralize warmup: compiling the numba kernels into {cache_dir()} "
          "(minutes the first time, seconds afterwards) ...", flush=True)  # fmt: skip
    out = warmup(plugins=args.plugins)
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    n = len(out["compiled"])
    what = f"{n} kernel(s) compiled" if n else "all kernels were cached"
    print(f"kernels ready in {out['seconds']:.1f} s: {what}")
    for name, sec in sorted(out["compiled"], key=lambda x: -x[1]):
        print(f"  {sec:7.1f} s  {name}")
    return 0


def add_commands(sub: Any) -> None:
    p = sub.add_parser("warmup", help="compile the numba kernels now (done once by install.sh)")
    p.add_argument("--plugins", action="store_true", help="also the plugins' kernels")
    p.add_argument("--json", action="store_true", help="print what was compiled as JSON")
    p.set_defaults(func=cmd_warmup)
