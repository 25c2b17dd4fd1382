"""JSON read at the door: bounded documents and a small schema checker.

Every JSON document auralize reads from a user (sessions, scene files,
speaker layouts, the ``meta`` of a sources file) goes through
:func:`parse_json` (or :func:`read_json` for a file), which refuses, in one
line naming the file, what the :mod:`json` module would otherwise turn into
an internal error or an absurd value:

* a file larger than :data:`MAX_BYTES`;
* nesting deeper than :data:`MAX_DEPTH` (``json`` recurses and raises
  ``RecursionError`` on deep documents; the depth is measured on the text
  before parsing);
* a number with more than :data:`MAX_DIGITS` digits in a row (``int`` refuses
  more than 4300 with a ``ValueError``; even far fewer make no sense as a
  size, a rate or a coordinate);
* ``NaN``, ``Infinity`` and numbers that overflow to infinity (``1e999``).

The parsed value is then checked against a schema built from a few node
types (:class:`Num`, :class:`Text`, :class:`Bool`, :class:`Null`,
:class:`Either`, :class:`ListOf`, :class:`Table`, :class:`Obj`,
:class:`DictOf`, :class:`AnyJSON`) with :func:`check`, whose messages read
``FILE: WHERE must be WHAT, got VALUE``.

Examples
--------
>>> from auralize.errors import FormatError
>>> schema = Obj({"rate": Num(lo=1, integer=True), "layout": Text()}, required=("rate",))
>>> check(parse_json('{"rate": 44100}', "s.json"), schema, "s.json")
>>> try:
...     check(parse_json('{"rate": "fast"}', "s.json"), schema, "s.json")
... except FormatError as exc:
...     print(exc)
s.json: rate must be an integer >= 1, got 'fast'
"""

from __future__ import annotations

import abc
import json
import math
import re
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from auralize.errors import AuralizeError, FormatError

#: deepest nesting of arrays and objects accepted
MAX_DEPTH = 64
#: most digits in a row a number may have (an integer's size, a fraction's precision)
MAX_DIGITS = 30
#: largest JSON file read, in bytes
MAX_BYTES = 64 * 1024 * 1024
#: integers beyond this magnitude are refused in checked values (as :data:`MAX_DIGITS`)
MAX_INT = 10**MAX_DIGITS

ErrorType = type[AuralizeError]
#: the ``what`` of a fault that is a key no schema knows (the valid keys follow)
_UNKNOWN = "\0unknown key; valid keys: "

# a JSON string literal (escapes included); unterminated strings are left to the parser
_STRING = re.compile(r'"(?:[^"\\\n]|\\.)*"')
_LONG_NUMBER = re.compile(rf"\d{{{MAX_DIGITS + 1},}}")
# with at most MAX_DIGITS digits in a row only a three-digit exponent can overflow a float
_BIG_EXPONENT = re.compile(r"-?[\d.]+[eE]\+?\d{3,}")


def _where(text: str, pos: int) -> str:
    line = text.count("\n", 0, pos) + 1
    return f"line {line}, column {pos - text.rfind(chr(10), 0, pos)}"


def _blank_strings(text: str) -> str:
    """``text`` with the inside of every string literal blanked (positions kept)."""
    return _STRING.sub(lambda m: '"' + " " * (len(m.group()) - 2) + '"', text)


def _refuse_constant(source: str, error: ErrorType) -> Callable[[str], Any]:
    def refuse(name: str) -> Any:
        raise error(f"{source}: {name} is not a number JSON allows here; numbers must be finite")

    return refuse


def parse_json(
    text: str, source: str, *, error: ErrorType = FormatError, nonfinite: bool = False
) -> Any:
    """Parse a JSON document within the bounds of the module docstring.

    Parameters
    ----------
    text : str
        The document.
    source : str
        Named in messages (a file name, ``"<memory>"``).
    error : AuralizeError subclass
        Raised for every refusal (default :class:`~auralize.errors.FormatError`).
    nonfinite : bool
        Accept ``NaN``, ``Infinity`` and overflowing numbers (what
        ``json.dumps`` writes for non-finite floats) instead of refusing them.

    Raises
    ------
    error
        Invalid JSON, too deep, too long a number, a non-finite number.
    """
    blank = _blank_strings(text)
    raw = blank.encode("utf-8", "surrogatepass")
    b = np.frombuffer(raw, dtype=np.uint8)
    opens = (b == ord("[")) | (b == ord("{"))
    closes = (b == ord("]")) | (b == ord("}"))
    depth = np.cumsum(opens.astype(np.int64) - closes)
    if depth.size and int(depth.max()) > MAX_DEPTH:
        pos = len(raw[: int(np.argmax(depth > MAX_DEPTH))].decode("utf-8", "replace"))
        raise error(
            f"{source}: JSON nested deeper than {MAX_DEPTH} levels (at {_where(text, pos)}); "
            f"auralize files nest a few levels"
        )
    m = _LONG_NUMBER.search(blank)
    if m:
        raise error(
            f"{source}: a number with {len(m.group())} digits at {_where(text, m.start())}; "
            f"numbers may have at most {MAX_DIGITS} digits"
        )
    for m in () if nonfinite else _BIG_EXPONENT.finditer(blank):
        try:
            finite = math.isfinite(float(m.group()))
        except ValueError:  # not a number: the parser says where
            continue
        if not finite:
            raise error(
                f"{source}: number {m.group()} at {_where(text, m.start())} overflows to "
                f"infinity; numbers must be finite"
            )
    try:
        if nonfinite:
            return json.loads(text)
        return json.loads(text, parse_constant=_refuse_constant(source, error))
    except json.JSONDecodeError as exc:
        raise error(f"{source}: not valid JSON ({exc})") from None
    except RecursionError:  # the depth scan above keeps json well inside the limit
        raise error(f"{source}: JSON nested too deeply (at most {MAX_DEPTH} levels)") from None


def read_json(path: str | Path, *, error: ErrorType = FormatError) -> Any:
    """Read and parse a JSON file (see :func:`parse_json`).

    ``FileNotFoundError`` is left to the caller (each names its kind of file);
    a file larger than :data:`MAX_BYTES` or not UTF-8 text raises ``error``.
    """
    p = Path(path)
    size = p.stat().st_size
    if size > MAX_BYTES:
        raise error(
            f"{p}: {size / 2**20:.1f} MiB is too large for a JSON file auralize reads "
            f"(at most {MAX_BYTES // 2**20} MiB)"
        )
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{p}: not UTF-8 JSON text ({exc.reason} at byte {exc.start})") from None
    return parse_json(text, str(p), error=error)


# ------------------------------------------------------------------ schemas
def _short(value: Any, limit: int = 60) -> str:
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= MAX_INT:
        return f"an integer of more than {MAX_DIGITS} digits"
    try:
        text = repr(value)
    except RecursionError:
        return f"a {type(value).__name__} nested more than {MAX_DEPTH} levels deep"
    return text if len(text) <= limit else f"{text[: limit - 4]}...{text[-1]}"


def _is_number(v: Any) -> bool:
    """A number, not a boolean, of at most :data:`MAX_DIGITS` integer digits (maybe infinite)."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        return False
    return not isinstance(v, int) or abs(v) < MAX_INT


class Schema(abc.ABC):
    """A node of a schema: :meth:`problem` says what is wrong with a value, or None."""

    what = "a value"

    @abc.abstractmethod
    def problem(self, value: Any, where: str) -> tuple[str, str, Any] | None:
        """``(where, what, value)`` of the first fault, or None when ``value`` fits."""


class Num(Schema):
    """A finite number (not a boolean), optionally an integer, within bounds."""

    def __init__(
        self,
        *,
        lo: float | None = None,
        hi: float | None = None,
        lo_open: bool = False,
        integer: bool = False,
        what: str | None = None,
    ) -> None:
        self.lo, self.hi, self.lo_open, self.integer = lo, hi, lo_open, integer
        if what is None:
            parts = ["an integer" if integer else "a number"]
            if lo is not None:
                parts.append(f"{'>' if lo_open else '>='} {lo:g}")
            if hi is not None:
                parts.append(f"{'and ' if lo is not None else ''}<= {hi:g}")
            what = " ".join(parts)
        self.what = what

    def problem(self, value: Any, where: str) -> tuple[str, str, Any] | None:
        if isinstance(value, bool) or not isinstance(value, int | float):
            return where, self.what, value
        if self.integer and not isinstance(value, int):
            return where, self.what, value
        if isinstance(value, int) and abs(value) >= MAX_INT:
            return where, self.what, value
        v = float(value)
        if not math.isfinite(v):
            return where, self.what, value
        if self.lo is not None and (v <= self.lo if self.lo_open else v < self.lo):
            return where, self.what, value
        if self.hi is not None and v > self.hi:
            return where, self.what, value
        return None


class Text(Schema):
    """A string, optionally non-empty or one of ``choices``."""

    def __init__(
        self,
        *,
        choices: Sequence[str] | None = None,
        nonempty: bool = False,
        what: str | None = None,
    ) -> None:
        self.choices = tuple(choices) if choices is not None else None
        self.nonempty = nonempty
        if what is None:
            what = (
                f"one of {list(self.choices)}"
                if self.choices is not None
                else "a non-empty string"
                if nonempty
                else "a string"
            )
        self.what = what

    def problem(self, value: Any, where: str) -> tuple[str, str, Any] | None:
        if not isinstance(value, str) or (self.nonempty and not value):
            return where, self.what, value
        if self.choices is not None and value not in self.choices:
            return where, self.what, value
        return None


class Bool(Schema):
    what = "true or false"

    def problem(self, value: Any, where: str) -> tuple[str, str, Any] | None:
        return None if isinstance(value, bool) else (where, self.what, value)


class Null(Schema):
    what = "null"

    def problem(self, value: Any, where: str) -> tuple[str, str, Any] | None:
        return None if value is None else (where, self.what, value)


class Either(Schema):
    """Any one of several schemas (the message lists what each accepts)."""

    def __init__(self, *options: Schema, what: str | None = None) -> None:
        self.options = options
        self.what = what or " or ".join(o.what for o in options)

    def problem(self, value: Any, where: str) -> tuple[str, str, Any] | None:
        found = [(o, o.problem(value, where)) for o in self.options]
        if any(f is None for _, f in found):
            return None
        # the one option whose kind the value has says what is wrong in it: a fault inside
        # the value first (a bad item), then one about the value itself (a missing key)
        inner = [f for _, f in found if f is not None and f[0] != where]
        if len(inner) == 1:
            return inner[0]
        specific = [f for o, f in found if f is not None and f[0] == where and f[1] != o.what]
        return specific[0] if len(specific) == 1 and not inner else (where, self.what, value)


def optional(schema: Schema) -> Schema:
    """``schema`` or null."""
    return Either(schema, Null(), what=f"{schema.what} or null")


class ListOf(Schema):
    """A list of items of one schema, with bounds on its length."""

    def __init__(
        self, item: Schema, *, min_len: int = 0, max_len: int | None = None, what: str | None = None
    ) -> None:
        self.item, self.min_len, self.max_len = item, min_len, max_len
        if what is None:
            n = (
                ""
                if min_len == 0 and max_len is None
                else f"{min_len} "
                if min_len == max_len
                else f"at least {min_len} "
                if max_len is None
                else f"{min_len} to {max_len} "
            )
            what = f"a list of {n}items, each {item.what}"
        self.what = what

    def problem(self, value: Any, where: str) -> tuple[str, str, Any] | None:
        if not isinstance(value, list):
            return where, self.what, value
        if len(value) < self.min_len or (self.max_len is not None and len(value) > self.max_len):
            return where, self.what, value
        for k, it in enumerate(value):
            found = self.item.problem(it, f"{where}[{k}]")
            if found is not None:
                return found
        return None


def vec3(what: str = "[x, y, z] (3 finite numbers)") -> ListOf:
    """Three finite numbers."""
    return ListOf(Num(), min_len=3, max_len=3, what=what)


class Table(Schema):
    """A list of rows of ``columns`` finite numbers (checked with numpy once the shape fits)."""

    def __init__(self, columns: int, *, min_rows: int = 0, what: str | None = None) -> None:
        self.columns, self.min_rows = columns, min_rows
        self.what = what or f"a list of rows of {columns} finite numbers"

    def problem(self, value: Any, where: str) -> tuple[str, str, Any] | None:
        if not isinstance(value, list | tuple) or len(value) < self.min_rows:
            return where, self.what, value
        for k, row in enumerate(value):
            if (
                not isinstance(row, list | tuple)
                or len(row) != self.columns
                or not all(map(_is_number, row))
            ):
                return f"{where}[{k}]", f"a row of {self.columns} finite numbers", row
        if value:
            bad = ~np.isfinite(np.asarray(value, dtype=np.float64)).all(axis=1)
            if bad.any():
                k = int(np.argmax(bad))
                return f"{where}[{k}]", f"a row of {self.columns} finite numbers", value[k]
        return None


class Obj(Schema):
    """A JSON object with known keys (each with its schema), some required.

    ``other``: the schema of keys not in ``fields`` (None: refused, with the
    valid keys in the message; :class:`AnyJSON` lets them through).
    ``empty_ok``: ``{}`` passes even when keys are required (an unset section).
    """

    def __init__(
        self,
        fields: Mapping[str, Schema],
        *,
        required: Sequence[str] = (),
        other: Schema | None = None,
        empty_ok: bool = False,
        what: str | None = None,
    ) -> None:
        self.fields, self.required, self.other = dict(fields), tuple(required), other
        self.empty_ok = empty_ok
        if what is None:
            what = (
                f"an object with {', '.join(repr(k) for k in self.required)}"
                if self.required
                else "an object"
            )
        self.what = what

    def problem(self, value: Any, where: str) -> tuple[str, str, Any] | None:
        if not isinstance(value, dict):
            return where, self.what, value
        if self.empty_ok and not value:
            return None
        missing = [k for k in self.required if k not in value]
        if missing:
            return where, f"{self.what} (missing {', '.join(map(repr, missing))})", value
        for k, v in value.items():
            key = f"{where}.{k}" if where else str(k)
            schema = self.fields.get(k, self.other)
            if schema is None:
                return key, f"{_UNKNOWN}{sorted(self.fields)}", v
            found = schema.problem(v, key)
            if found is not None:
                return found
        return None


class DictOf(Schema):
    """An object whose keys are free (or one of ``keys``) and whose values share a schema."""

    def __init__(
        self, value: Schema, *, keys: Sequence[str] | None = None, what: str | None = None
    ) -> None:
        self.value, self.keys = value, tuple(keys) if keys is not None else None
        self.what = what or f"an object of {value.what}"

    def problem(self, value: Any, where: str) -> tuple[str, str, Any] | None:
        if not isinstance(value, dict):
            return where, self.what, value
        for k, v in value.items():
            key = f"{where}.{k}" if where else str(k)
            if self.keys is not None and k not in self.keys:
                return key, f"{_UNKNOWN}{list(self.keys)}", v
            found = self.value.problem(v, key)
            if found is not None:
                return found
        return None


class AnyJSON(Schema):
    """Any JSON value (walked without recursion): bounded depth, finite numbers of bounded size.

    Needed for values made in Python (an API call), which :func:`parse_json`
    has not bounded.
    """

    what = f"a JSON value (finite numbers, at most {MAX_DEPTH} levels deep)"

    def problem(self, value: Any, where: str) -> tuple[str, str, Any] | None:
        stack: list[tuple[Any, int]] = [(value, 0)]
        while stack:
            v, depth = stack.pop()
            if depth > MAX_DEPTH:
                return where, self.what, value
            if isinstance(v, dict):
                if not all(isinstance(k, str) for k in v):
                    return where, self.what, value
                stack.extend((x, depth + 1) for x in v.values())
            elif isinstance(v, list | tuple):
                stack.extend((x, depth + 1) for x in v)
            elif isinstance(v, bool) or v is None or isinstance(v, str):
                continue
            elif isinstance(v, int | float):
                if Num().problem(v, where) is not None:
                    return where, self.what, value
            else:
                return where, self.what, value
        return None


def check(
    value: Any, schema: Schema, source: str, *, where: str = "", error: ErrorType = FormatError
) -> None:
    """Raise ``error`` (``SOURCE: WHERE must be WHAT, got VALUE``) if ``value`` does not fit."""
    found = schema.problem(value, where)
    if found is not None:
        at, what, got = found
        at = at or "the document"
        if what.startswith(_UNKNOWN):
            raise error(f"{source}: unknown key {at!r}; valid keys: {what[len(_UNKNOWN) :]}")
        raise error(f"{source}: {at} must be {what}, got {_short(got)}")
