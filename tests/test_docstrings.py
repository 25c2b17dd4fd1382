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
module of a package in :data:`DOCUMENTED_PACKAGES` (its public sub-packages'
included) must be listed, and the package's own ``__init__`` too when it defines
public callables (one that only re-exports, lazily, has nothing of its own).
"""

from __future__ import annotations

import functools
import importlib
import importlib.util
import inspect
import pathlib
import pkgutil
import re
import sys
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
    "auralize.emitters.synthesis",
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
DOCUMENTED_PACKAGES: tuple[str, ...] = (
    "auralize.emitters",
    "auralize.io",
    "auralize.sources",
    "auralize.spatial",
)


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


def _is_package(module_name: str) -> bool:
    """Whether ``module_name`` is a package (its ``__init__``)."""
    return hasattr(importlib.import_module(module_name), "__path__")


def public_modules(package: str) -> list[str]:
    """The public modules of ``package`` (names not starting with ``_``), those of its
    public sub-packages included (the sub-packages themselves too), sorted."""
    pkg = importlib.import_module(package)
    out = []
    for info in pkgutil.iter_modules(pkg.__path__):
        if info.name.startswith("_"):
            continue
        name = f"{package}.{info.name}"
        out.append(name)
        if info.ispkg:
            out.extend(public_modules(name))
    return sorted(out)


def unchecked_modules(package: str, documented: tuple[str, ...]) -> list[str]:
    """What of ``package`` the rule should check but ``documented`` does not list: its
    public modules, and the package itself (and each public sub-package) when it
    defines public callables of its own."""
    candidates = [package, *public_modules(package)]
    return [
        m
        for m in candidates
        if m not in documented and not (_is_package(m) and not list(public_callables(m)))
    ]


def empty_listed(modules: tuple[str, ...]) -> list[str]:
    """Modules of ``modules`` with nothing to check that are not a package's ``__init__``
    (a typo, a moved module; a package that only re-exports may be listed)."""
    return [m for m in modules if not _is_package(m) and not list(public_callables(m))]


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
    assert not empty_listed(DOCUMENTED_MODULES)


@pytest.mark.parametrize("package", DOCUMENTED_PACKAGES)
def test_every_public_module_of_a_documented_package_is_checked(package: str) -> None:
    """A new public module of a documented package is checked as soon as it exists."""
    assert public_modules(package), f"{package} has no public modules"
    missing = unchecked_modules(package, DOCUMENTED_MODULES)
    assert not missing, f"public modules of {package} not in DOCUMENTED_MODULES: {missing}"


def test_a_package_that_only_re_exports_need_not_be_listed() -> None:
    # auralize.sources and auralize.spatial define no public callables of their own
    assert list(public_callables("auralize.sources")) == []
    unlisted = unchecked_modules("auralize.sources", ())
    assert "auralize.sources" not in unlisted and "auralize.sources.detection" in unlisted
    # one that defines its own is checked: auralize.emitters (Emitter, ...)
    assert unchecked_modules("auralize.emitters", ())[0] == "auralize.emitters"
    # listed, an empty package is allowed, an empty plain module is not
    assert empty_listed(("auralize.sources", "auralize.constants")) == ["auralize.constants"]


def test_checker_counts_what_a_package_exports_from_private_modules() -> None:
    found = {qual: kind for qual, _, kind in public_callables("auralize.io")}
    assert found["ResampledWarning"] == "class"  # defined in auralize.io._common
    assert "require_exists" not in found  # imported from there, not exported


@pytest.mark.parametrize("module_name", ["auralize.emitters.synthesis", "auralize.io"])
def test_the_api_reference_documents_what_the_rule_checks(module_name: str) -> None:
    """The docs extension puts a module's exports from private modules on its page:
    the same names the rule checks with the module."""
    # the module alone, by its file (the extension's package needs Sphinx)
    path = pathlib.Path(__file__).parents[1] / "docs" / "_ext" / "auralize_docs" / "exports.py"
    spec = importlib.util.spec_from_file_location("_auralize_docs_exports", path)
    assert spec is not None and spec.loader is not None
    exports = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(exports)

    mod = importlib.import_module(module_name)
    on_page = {name for _, name in exports.exported_from_private(mod)}
    checked = {q for q, obj, _ in public_callables(module_name) if "." not in q}
    own = {q for q in checked if getattr(mod, q).__module__ == module_name}
    assert on_page and on_page == checked - own


# ------------------------------------------------------------ the checker itself
_DOCUMENTED_MODULE = '''"""A documented module."""


def half(x: float) -> float:
    """Half of ``x``.

    Parameters
    ----------
    x : float
        A number.

    Returns
    -------
    float
        ``x / 2``.

    Examples
    --------
    >>> half(3.0)
    1.5
    """
    return x / 2
'''


def test_a_new_undocumented_module_of_a_documented_package_is_caught(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A real package on disk: an ``__init__`` with nothing of its own, a listed module,
    private ones, and new public modules (one a sub-package) that nobody listed."""
    pkg = tmp_path / "sdoc_demo"
    (pkg / "_inner").mkdir(parents=True)
    (pkg / "sub").mkdir()
    (pkg / "__init__.py").write_text('"""Re-exports only."""\n')
    (pkg / "done.py").write_text(_DOCUMENTED_MODULE)
    (pkg / "fresh.py").write_text("def new(x):\n    return x\n")
    (pkg / "_private.py").write_text("def hidden(x):\n    return x\n")
    (pkg / "_inner" / "__init__.py").write_text("")
    (pkg / "_inner" / "deep.py").write_text("def hidden(x):\n    return x\n")
    (pkg / "sub" / "__init__.py").write_text("def own(x):\n    return x\n")
    (pkg / "sub" / "leaf.py").write_text(_DOCUMENTED_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        assert public_modules("sdoc_demo") == [
            "sdoc_demo.done",
            "sdoc_demo.fresh",
            "sdoc_demo.sub",
            "sdoc_demo.sub.leaf",
        ]
        listed = ("sdoc_demo.done", "sdoc_demo.sub.leaf")
        assert unchecked_modules("sdoc_demo", listed) == ["sdoc_demo.fresh", "sdoc_demo.sub"]
        # listed, the new module is checked, and its undocumented function flagged
        assert not unchecked_modules("sdoc_demo", (*listed, "sdoc_demo.fresh", "sdoc_demo.sub"))
        ((qual, obj, kind),) = public_callables("sdoc_demo.fresh")
        assert qual == "new" and "new: no docstring" in problems(obj, kind=kind, name=qual)
        assert [
            p for q, o, k in public_callables("sdoc_demo.done") for p in problems(o, kind=k)
        ] == []
    finally:
        for name in [m for m in sys.modules if m.split(".")[0] == "sdoc_demo"]:
            del sys.modules[name]


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
