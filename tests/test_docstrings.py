"""The docstring rule: every public function, class, method and property of the
modules in :data:`DOCUMENTED_MODULES` has a numpydoc docstring with a
``Parameters`` section naming each of its arguments (when it takes any besides
``self``/``cls``), a ``Returns`` (or ``Yields``) section when its annotation says
it returns something other than None, and an ``Examples`` section with a
runnable example (``>>>``; the doctests run with the suite, ``--doctest-modules``).

Classes document their constructor's arguments in the class docstring;
properties are documented as attributes are (a summary and an example, no
``Parameters`` or ``Returns``); exceptions and warnings need no ``Parameters``.
What a module exports (``__all__``) from a private module (``auralize.io``'s
``ResampledWarning``, defined in ``auralize.io._common``) is checked with it.
Extend :data:`DOCUMENTED_MODULES` as more modules meet the rule; every public
module of a package in :data:`DOCUMENTED_PACKAGES` must be listed.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import pkgutil
import re
from collections.abc import Callable, Iterator

import pytest

#: modules whose public callables meet the docstring rule
DOCUMENTED_MODULES: tuple[str, ...] = (
    "auralize.pipeline",
    "auralize.rendering",
    "auralize.listener",
    "auralize.volume",
    "auralize.emitters",
    "auralize.emitters.engine",
    "auralize.emitters.events",
    "auralize.emitters.outdoor",
    "auralize.emitters.parallel",
    "auralize.emitters.propagation",
    "auralize.emitters.reference",
    "auralize.emitters.timbre",
    "auralize.audio.output",
    "auralize.spatial.ambisonics",
    "auralize.spatial.hrtf",
    "auralize.spatial.layouts",
    "auralize.spatial.sofa",
    "auralize.sources.detection",
    "auralize.sources.field",
    "auralize.sources.mapping",
    "auralize.sources.sources_file",
    "auralize.io",
    "auralize.io.backends",
    "auralize.io.foreign",
    "auralize.io.hdf5",
    "auralize.io.netcdf",
    "auralize.io.openfoam",
    "auralize.io.options",
    "auralize.io.paraview",
    "auralize.io.resample",
    "auralize.io.vtk_readers",
    "auralize.io.vtkhdf_write",
    "auralize.io.xdmf_check",
)

#: packages whose public modules (names not starting with ``_``) all meet the rule
DOCUMENTED_PACKAGES: tuple[str, ...] = ("auralize.io",)


def _section(doc: str, name: str) -> str | None:
    """Body of the numpydoc section ``name`` (a title underlined with dashes), or None."""
    m = re.search(rf"^[ \t]*{name}[ \t]*\n[ \t]*-{{3,}}[ \t]*\n", doc, re.M)
    if m is None:
        return None
    rest = doc[m.end() :]
    nxt = re.search(r"^[ \t]*\w[\w ]*\n[ \t]*-{3,}[ \t]*$", rest, re.M)
    return rest if nxt is None else rest[: nxt.start()]


def _documented_names(section: str) -> set[str]:
    """Parameter names of a Parameters section: ``name : type`` or ``a, b : type`` lines."""
    names: set[str] = set()
    for line in section.splitlines():
        if not line or line[0].isspace():
            continue
        head = line.split(":", 1)[0] if ":" in line else line
        names.update(n.strip().lstrip("*") for n in head.split(","))
    return names


def _arguments(fn: Callable[..., object]) -> list[str]:
    """Argument names of ``fn`` besides ``self``/``cls`` (``*args``/``**kw`` included)."""
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):
        return []
    return [p for p in sig.parameters if p not in ("self", "cls")]


def _returns_value(fn: Callable[..., object]) -> bool:
    """Whether the return annotation says something other than None (unannotated: yes)."""
    try:
        ann = inspect.signature(fn).return_annotation
    except (TypeError, ValueError):
        return False
    return ann not in (None, "None", type(None))


def problems(obj: object, *, kind: str = "function", name: str | None = None) -> list[str]:
    """What the docstring of ``obj`` lacks under the rule (empty: it meets it).

    ``kind`` is ``"function"`` (functions and methods), ``"class"`` or ``"property"``.
    """
    label = name or getattr(obj, "__qualname__", repr(obj))
    doc = inspect.getdoc(obj) if kind != "property" else getattr(obj, "__doc__", None)
    if not doc or not doc.strip():
        return [f"{label}: no docstring"]
    doc = inspect.cleandoc(doc)
    out = []
    if not doc.splitlines()[0].strip():
        out.append(f"{label}: no one-line summary")
    examples = _section(doc, "Examples")
    if examples is None or ">>>" not in examples:
        out.append(f"{label}: no Examples section with a runnable (>>>) example")
    if kind == "property":
        return out
    is_exception = isinstance(obj, type) and issubclass(obj, BaseException)
    is_protocol = isinstance(obj, type) and getattr(obj, "_is_protocol", False)
    args = [] if is_exception or is_protocol else _arguments(obj)  # type: ignore[arg-type]
    if args:
        params = _section(doc, "Parameters")
        if params is None:
            out.append(f"{label}: no Parameters section (arguments {', '.join(args)})")
        else:
            missing = [a for a in args if a not in _documented_names(params)]
            if missing:
                out.append(f"{label}: Parameters does not describe {', '.join(missing)}")
    if kind == "function" and _returns_value(obj):  # type: ignore[arg-type]
        if _section(doc, "Returns") is None and _section(doc, "Yields") is None:
            out.append(f"{label}: no Returns section")
    return out


def _exported_from_private(mod: object, name: str, obj: object) -> bool:
    """Whether ``obj`` is in the module's ``__all__`` and defined in a private module."""
    home = getattr(obj, "__module__", None) or ""
    exported = name in getattr(mod, "__all__", ())
    return exported and any(part.startswith("_") for part in home.split("."))


def public_callables(module_name: str) -> Iterator[tuple[str, object, str]]:
    """``(qualified name, object, kind)`` of every public callable a module defines
    (or exports from a private module): its functions and classes, and the classes'
    own public methods and properties."""
    mod = importlib.import_module(module_name)
    for name, obj in sorted(vars(mod).items()):
        if name.startswith("_"):
            continue
        home = getattr(obj, "__module__", None)
        if home != module_name and not _exported_from_private(mod, name, obj):
            continue
        if isinstance(obj, type):
            yield name, obj, "class"
            for attr, member in sorted(vars(obj).items()):
                if attr.startswith("_"):
                    continue
                if isinstance(member, property):
                    yield f"{name}.{attr}", member, "property"
                elif isinstance(member, functools.cached_property):
                    yield f"{name}.{attr}", member, "property"
                elif isinstance(member, staticmethod | classmethod):
                    yield f"{name}.{attr}", member.__func__, "function"
                elif inspect.isfunction(member):
                    yield f"{name}.{attr}", member, "function"
        elif callable(obj):
            yield name, obj, "function"


def tally(module_name: str) -> tuple[int, int, int]:
    """Public callables of a module; how many have Parameters; how many an example."""
    n = n_params = n_examples = 0
    for _, obj, kind in public_callables(module_name):
        n += 1
        doc = inspect.cleandoc(
            (obj.__doc__ if kind == "property" else inspect.getdoc(obj)) or ""  # type: ignore[union-attr]
        )
        n_params += _section(doc, "Parameters") is not None
        ex = _section(doc, "Examples")
        n_examples += ex is not None and ">>>" in ex
    return n, n_params, n_examples


@pytest.mark.parametrize("module_name", DOCUMENTED_MODULES)
def test_public_callables_meet_the_docstring_rule(module_name: str) -> None:
    found = list(public_callables(module_name))
    bad = [p for qual, obj, kind in found for p in problems(obj, kind=kind, name=qual)]
    assert not bad, f"{module_name}: {len(bad)} docstring problems:\n" + "\n".join(bad)


def test_every_documented_module_has_public_callables() -> None:
    """A module listed with nothing to check (a typo, a moved module) is an error."""
    empty = [m for m in DOCUMENTED_MODULES if not list(public_callables(m))]
    assert not empty


@pytest.mark.parametrize("package", DOCUMENTED_PACKAGES)
def test_every_public_module_of_a_documented_package_is_checked(package: str) -> None:
    """A new public module of a documented package is checked as soon as it exists."""
    pkg = importlib.import_module(package)
    modules = [package] + [
        f"{package}.{m.name}" for m in pkgutil.iter_modules(pkg.__path__) if m.name[0] != "_"
    ]
    missing = [m for m in modules if m not in DOCUMENTED_MODULES]
    assert len(modules) > 1 and not missing, (
        f"public modules of {package} not in DOCUMENTED_MODULES: {missing}"
    )


def test_checker_counts_what_a_package_exports_from_private_modules() -> None:
    found = {qual: kind for qual, _, kind in public_callables("auralize.io")}
    assert found["ResampledWarning"] == "class"  # defined in auralize.io._common
    assert "require_exists" not in found  # imported from there, not exported


# ------------------------------------------------------------ the checker itself
def _undocumented(volume, *, rate: int = 48000) -> float:  # type: ignore[no-untyped-def]
    """Scale a volume."""
    return 1.0


def _documented(volume: object, *, rate: int = 48000) -> float:
    """Scale a volume.

    Parameters
    ----------
    volume : TimeVolume
        The data.
    rate : int
        Sample rate in Hz.

    Returns
    -------
    float
        The scale.

    Examples
    --------
    >>> _documented(None)
    1.0
    """
    return 1.0


def test_checker_flags_a_function_that_breaks_the_rule() -> None:
    found = problems(_undocumented)
    assert any("no Parameters section (arguments volume, rate)" in p for p in found)
    assert any("no Returns section" in p for p in found)
    assert any("no Examples section" in p for p in found)
    assert problems(_documented) == []


def test_checker_flags_an_argument_missing_from_parameters() -> None:
    def half(volume: object, *, rate: int) -> None:
        """Half.

        Parameters
        ----------
        volume : object
            Anything.

        Examples
        --------
        >>> 1
        1
        """

    assert problems(half, name="half") == ["half: Parameters does not describe rate"]


def test_checker_wants_a_runnable_example_and_a_docstring() -> None:
    def prose() -> None:
        """Prose only.

        Examples
        --------
        Call it.
        """

    def bare() -> None:
        pass

    assert any("runnable" in p for p in problems(prose))
    assert problems(bare)[0].endswith("no docstring")
    assert problems(property(lambda self: 1), kind="property", name="p") == ["p: no docstring"]
