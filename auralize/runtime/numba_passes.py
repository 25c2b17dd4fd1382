"""Two of numba's compiler passes in time linear in a kernel's size, not quadratic.

numba's frontend spends most of a large kernel's cold compile in two passes
whose cost grows with the kernel's size times something else that grows with
it:

* the inliner of ``inline="always"`` helpers (``InlineWorker.inline_function``)
  deep-copies the IR it has just built for one call site, twice, one block at a
  time; each block's copy takes a copy of the callee's whole variable scope
  along: blocks × variables per inlined call (:func:`fast_inlining`);
* the SSA reconstruction (``ssa._run_ssa``) rewrites every statement of the
  function once for each variable assigned more than once: statements ×
  reassigned variables (:func:`fast_ssa`).

The replacements do the same work without the copies, and over the blocks that
mention a variable only; the LLVM IR they lead to is numba's own, instruction
for instruction (``tests/test_compile_once.py`` compiles kernels both ways and
compares).  They replace numba internals, so they are applied
(:func:`apply`, from :func:`auralize.runtime.jit.configure`) only where they
were checked:

* numba's version lies in :data:`VERIFIED_NUMBA` (the releases whose passes
  were read and whose compiled code was compared), and
* every numba function a replacement stands for or relies on has the source it
  was written against (:data:`NUMBA_SOURCES`: a digest of its text).

Otherwise numba's own passes run (slower to compile, the same code), and
``AURALIZE_FAST_COMPILE=0`` keeps them anyway.
"""

from __future__ import annotations

import copy as _copy
import hashlib
import importlib
import inspect
import logging
import os
import re
import threading
from collections import defaultdict
from typing import Any

log = logging.getLogger("auralize")

#: the oldest and newest numba releases the replacements were checked on (both
#: included): numba's sources of the passes are the same from 0.60.0 to 0.68.1
#: (0.60 logs with ``pformat`` where later releases log lazily)
VERIFIED_NUMBA: tuple[tuple[int, int, int], tuple[int, int, int]] = ((0, 60, 0), (0, 68, 1))

_INLINE = "numba.core.inline_closurecall:InlineWorker"
_SSA = "numba.core.ssa"
#: per replacement, the numba functions (``module:qualified name``) it replaces or
#: relies on, with the digests (:func:`source_digest`) of the sources it was written
#: against.  The inliner: its ``inline_function`` and the ``inline_ir`` whose copies it
#: skips; the one caller, ``InlineInlinables._do_work``, ignores the IR copy it no
#: longer returns.  The SSA pass: ``_run_ssa`` and the handlers and steps it runs.
NUMBA_SOURCES: dict[str, dict[str, frozenset[str]]] = {
    "inlining": {
        f"{_INLINE}.inline_function": frozenset({"1b53f183258e659d"}),
        f"{_INLINE}.inline_ir": frozenset({"26fd2b7600c9d929"}),
        "numba.core.untyped_passes:InlineInlinables._do_work": frozenset({"5e0a1f246f0fcb5d"}),
    },
    "ssa": {
        # 0.60.0; 0.61 and later
        f"{_SSA}:_run_ssa": frozenset({"5897fcf654df3886", "c497422bcf049990"}),
        f"{_SSA}:_fresh_vars": frozenset({"4a4d13bc0ec57cfb"}),
        f"{_SSA}:_fix_ssa_vars": frozenset({"3f183045a5355bf4"}),
        f"{_SSA}:_run_block_rewrite": frozenset({"d17efdbed57062bf"}),
        f"{_SSA}:_run_ssa_block_pass": frozenset({"b48d590f81cc8b20"}),
        f"{_SSA}:_make_states": frozenset({"4b44d7827493e4b7"}),
        f"{_SSA}:_FreshVarHandler": frozenset({"8b6650f7113790e5"}),
        f"{_SSA}:_FixSSAVars": frozenset({"4113314a369d1dea"}),
        f"{_SSA}:_CacheListVars": frozenset({"5258bb7ea7f47240"}),
    },
}

#: numba's functions that a replacement took the place of, by ``module:qualified name``
_REPLACED: dict[str, Any] = {}


def numba_version(text: str | None = None) -> tuple[int, int, int] | None:
    """``(major, minor, micro)`` of numba's version string ``text`` (default: the
    installed numba's); None when it does not start with three numbers.  A
    pre-release counts as its release (0.69.0rc1 is 0.69.0)."""
    if text is None:
        import numba

        text = str(numba.__version__)
    m = re.match(r"(\d+)\.(\d+)\.(\d+)", text)
    return None if m is None else (int(m[1]), int(m[2]), int(m[3]))


def _numba_object(name: str) -> Any:
    """The numba function or class ``module:qualified name`` as numba defines it (the
    original when a replacement has taken its place)."""
    if name in _REPLACED:
        return _REPLACED[name]
    module, qualname = name.split(":")
    obj: Any = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    return obj


def source_digest(obj: Any) -> str:
    """The first 16 hex digits of the SHA-256 of ``obj``'s source text."""
    return hashlib.sha256(inspect.getsource(obj).encode()).hexdigest()[:16]


def refusal(name: str, version: str | None = None) -> str | None:
    """Why replacement ``name`` (``"inlining"`` or ``"ssa"``) may not take the place of
    numba's pass with numba ``version`` (default: the installed numba), or None when it
    may: the version outside :data:`VERIFIED_NUMBA`, or a numba source not the one
    listed in :data:`NUMBA_SOURCES` (or not readable)."""
    found = numba_version(version)
    lo, hi = VERIFIED_NUMBA
    if found is None or not lo <= found <= hi:
        shown = ".".join(map(str, found)) if found else repr(version)
        return f"numba {shown} is outside the versions checked ({lo[1]}.{lo[2]} to {hi[1]}.{hi[2]})"
    for qualname, digests in NUMBA_SOURCES[name].items():
        try:
            digest = source_digest(_numba_object(qualname))
        except (ImportError, AttributeError, OSError, TypeError) as exc:
            return f"{qualname} not readable ({exc})"
        if digest not in digests:
            return f"{qualname} is not the source checked (digest {digest})"
    return None


def apply() -> dict[str, bool]:
    """Put the replacements in the place of numba's passes where they may be (see the
    module's docstring); returns which are in place.  Idempotent."""
    if os.environ.get("AURALIZE_FAST_COMPILE", "1") == "0":
        return {"inlining": False, "ssa": False}
    return {"inlining": fast_inlining(), "ssa": fast_ssa()}


_INLINE_TLS = threading.local()


class _InlinerCopy:
    """The ``copy`` module as :mod:`numba.core.inline_closurecall` sees it once
    :func:`fast_inlining` is applied: ``deepcopy`` of an IR block returns the block
    itself while a callee's freshly built IR is spliced in, and is the standard
    deep copy otherwise."""

    def __getattr__(self, name: str) -> Any:
        return getattr(_copy, name)

    @staticmethod
    def deepcopy(x: Any, memo: Any = None) -> Any:
        from numba.core import ir

        if getattr(_INLINE_TLS, "fresh", False) and isinstance(x, ir.Block):
            return x
        return _copy.deepcopy(x, memo)


def _inline_function(  # noqa: PLR0917 (numba's method, its signature)
    self: Any, caller_ir: Any, block: Any, i: int, function: Any, arg_typs: Any = None
) -> tuple[Any, ...]:
    """numba's ``InlineWorker.inline_function`` (the ``inline="always"`` inliner of the
    untyped passes) without copying the callee's IR, which it has just built for this
    call site alone.  The first item, the callee's IR before the splice, is None
    (numba's one caller ignores it).  An inliner that types the callee as well (with a
    typemap: its typing may compile other functions, whose cached IR must be copied)
    is numba's own."""
    if self._permit_update_type_and_call_maps:
        original = _REPLACED[f"{_INLINE}.inline_function"]
        return original(self, caller_ir, block, i, function, arg_typs=arg_typs)  # type: ignore[no-any-return]
    callee_ir = self.run_untyped_passes(function)
    _INLINE_TLS.fresh = True
    try:
        out = self.inline_ir(
            caller_ir, block, i, callee_ir, function.__code__.co_freevars, arg_typs=arg_typs
        )
    finally:
        _INLINE_TLS.fresh = False
    return (None, *out[1:])


def fast_inlining() -> bool:
    """Splice ``inline="always"`` callees into their callers without copying them;
    returns whether this replacement is in place.

    numba's inliner builds the callee's IR afresh for every call site (its untyped
    passes), then deep-copies it twice before splicing it in, one block at a time;
    the copy of every block drags a copy of the callee's whole variable scope along,
    so an inlined function costs its blocks × its variables, and nested inlined
    helpers (the synthesis kernels' SIMD loops are built of them) most of a kernel's
    cold compile.  The copies guard IR that is used again; the IR of this call site is
    not (the inliner of ``@overload`` functions, whose IR is cached, still copies).
    Only where :func:`refusal` finds nothing against it.
    """
    import numba.core.inline_closurecall as icc

    worker = icc.InlineWorker
    if worker.inline_function is _inline_function:
        return True
    why = refusal("inlining")
    if why is None and getattr(icc, "copy", None) is not _copy:
        why = "numba.core.inline_closurecall.copy is not the copy module"
    if why is not None:
        log.debug("numba's own inliner: %s", why)
        return False
    _REPLACED[f"{_INLINE}.inline_function"] = worker.inline_function
    icc.copy = _InlinerCopy()  # type: ignore[assignment]
    worker.inline_function = _inline_function  # type: ignore[method-assign]
    return True


def _rewrite_blocks(blocks: Any, states: Any, handler: Any, labels: set[Any]) -> Any:
    """numba's ``ssa._run_block_rewrite`` over the blocks ``labels`` only; the other
    blocks, which do not mention the variable being renamed, keep their statements
    (as its handlers leave them)."""
    from numba.core import ir, ssa

    newblocks = {}
    for label, blk in blocks.items():
        newblk = ir.Block(scope=blk.scope, loc=blk.loc)
        if label in labels:
            states["label"] = label
            states["block"] = blk
            newblk.body = list(ssa._run_ssa_block_pass(states, blk, handler))
        else:
            newblk.body = list(blk.body)
        newblocks[label] = newblk
    return newblocks


def _run_ssa(blocks: Any) -> Any:
    """numba's ``ssa._run_ssa`` (SSA reconstruction, one variable assigned more than
    once at a time) with each variable's two rewrites over the blocks that mention it,
    not over the whole function: the same renamed variables and phi nodes, in time
    linear in the function instead of in its size times its reassigned variables.

    A block that does not mention the variable is one numba's rewrite leaves as it
    is: its handlers act on the statements that assign or use the variable only (and
    a phi node that a use elsewhere calls for is placed through the shared maps,
    whatever block it lands in).  The blocks mentioning a variable are found once,
    before any rewrite: renaming one variable never makes a block mention another.
    """
    from numba.core import errors, ssa

    if not blocks:
        return {}
    cfg = ssa.compute_cfg_from_blocks(blocks)
    df_plus = ssa._iterated_domfronts(cfg)
    violators = ssa._find_defs_violators(blocks, cfg)
    cache_list_vars = ssa._CacheListVars()
    mentioned: dict[str, set[Any]] = {name: set() for name in violators}
    for label, blk in blocks.items():
        for stmt in blk.body:
            for var in cache_list_vars.get(stmt):
                where = mentioned.get(var.name)
                if where is not None:
                    where.add(label)
    for varname in violators:
        labels = mentioned[varname]
        # fresh variables for every assignment to it ...
        states = ssa._make_states(blocks)
        states["varname"] = varname
        defmap: defaultdict[Any, list[Any]] = defaultdict(list)
        states["defmap"] = defmap
        blocks = _rewrite_blocks(blocks, states, ssa._FreshVarHandler(), labels)
        # ... and every use taken to its reaching definition (phi nodes where needed)
        states = ssa._make_states(blocks)
        states["varname"] = varname
        states["defmap"] = defmap
        phimap: defaultdict[Any, list[Any]] = defaultdict(list)
        states["phimap"] = phimap
        states["cfg"] = cfg
        states["phi_locations"] = ssa._compute_phi_locations(df_plus, defmap)
        blocks = _rewrite_blocks(blocks, states, ssa._FixSSAVars(cache_list_vars), labels)
        for label, philist in phimap.items():
            blocks[label].body = philist + blocks[label].body
    if ssa.compute_cfg_from_blocks(blocks) != cfg:
        raise errors.CompilerError("CFG mutated in SSA pass")
    return blocks


def fast_ssa() -> bool:
    """Rebuild SSA form in time linear in a function's size; returns whether this
    replacement is in place.

    numba turns every variable assigned more than once (a loop's accumulator, a value
    clamped in place, every such variable of every inlined copy of a helper) into
    single assignments one variable at a time, each time rewriting every statement of
    the function: its size times its reassigned variables, which the inlined copies
    make large together.  Here each variable's rewrite visits the blocks that mention it
    (:func:`_run_ssa`).  Only where :func:`refusal` finds
    nothing against it.
    """
    from numba.core import ssa

    if ssa._run_ssa is _run_ssa:
        return True
    why = refusal("ssa")
    if why is not None:
        log.debug("numba's own SSA reconstruction: %s", why)
        return False
    _REPLACED[f"{_SSA}:_run_ssa"] = ssa._run_ssa
    ssa._run_ssa = _run_ssa
    return True
