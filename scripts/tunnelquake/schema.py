"""A small declarative schema for YAML case files, with errors that name key, value, line and fix.

A schema is a tree of :class:`Spec` objects. :func:`validate` walks the data and the tree
together, converts quantities to SI, fills defaults, and collects *every* problem it finds as an
:class:`Issue` (so a user fixes a case in one pass, not one error per run).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import yaml

from . import units as U


# --------------------------------------------------------------------------------------------
# YAML with line numbers and duplicate-key detection
# --------------------------------------------------------------------------------------------
class LineDict(dict):
    """A dict that remembers the YAML line of itself and of each of its keys."""

    line: int = 0

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        self.key_lines: dict[Any, int] = {}


class LineList(list):
    line: int = 0


class _Loader(yaml.SafeLoader):
    pass


def _construct_mapping(loader: _Loader, node: yaml.MappingNode) -> LineDict:
    loader.flatten_mapping(node)
    out = LineDict()
    out.line = node.start_mark.line + 1
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        line = key_node.start_mark.line + 1
        if key in out:
            raise yaml.constructor.ConstructorError(
                None, None,
                f"key '{key}' appears twice (lines {out.key_lines[key]} and {line}); keep one",
                key_node.start_mark)
        out[key] = loader.construct_object(value_node, deep=True)
        out.key_lines[key] = line
    return out


def _construct_sequence(loader: _Loader, node: yaml.SequenceNode) -> LineList:
    out = LineList(loader.construct_object(child, deep=True) for child in node.value)
    out.line = node.start_mark.line + 1
    return out


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _construct_sequence)


def load_yaml(text: str):
    return yaml.load(text, Loader=_Loader)  # noqa: S506 - a SafeLoader subclass


# --------------------------------------------------------------------------------------------
# Problems
# --------------------------------------------------------------------------------------------
@dataclass
class Issue:
    path: str  # dotted key, e.g. materials.rock.poisson_ratio
    value: Any  # the offending value as written (or None for a missing key)
    problem: str
    fix: str
    line: int | None = None

    def format(self, filename: str) -> str:
        where = f"{filename}:{self.line}" if self.line else filename
        shown = "" if self.value is _MISSING else f" = {self.value!r}"
        return f"{where}: {self.path}{shown}: {self.problem}. Fix: {self.fix}"


_MISSING = object()

#: keys whose neutral value means "not used": a section (its key, its neutral value) or a dotted key (its
#: neutral value). The fingerprints count them only away from that value, so a section or key added to
#: the schema leaves the fingerprints of the cases that do not use it as they were.
NEUTRAL = {"incident_wave": ("type", "none"), "lining_joints": ("spacing", None), "mesh.tunnel_end_plugs": 0,
           "lining_joints.held_at": "along_ring", "coupling.defect_correction": 0.0, "mesh.symmetry": "none",
           "coupling.residual_scale": "current"}


class CaseError(Exception):
    """The case file has problems; ``issues`` lists each one."""

    def __init__(self, filename: str, issues: list[Issue]):
        self.filename = filename
        self.issues = issues
        lines = [i.format(filename) for i in issues]
        head = f"{filename}: {len(issues)} problem{'s' if len(issues) != 1 else ''} in the case file"
        super().__init__(head + "\n  " + "\n  ".join(lines))


# --------------------------------------------------------------------------------------------
# Specs
# --------------------------------------------------------------------------------------------
@dataclass
class Spec:
    doc: str = ""
    required: bool = False
    default: Any = _MISSING

    def check(self, value, path: str, line: int | None, ctx: Context):
        raise NotImplementedError

    def example(self) -> str:
        return ""


@dataclass
class Context:
    issues: list[Issue] = field(default_factory=list)

    def error(self, path, value, problem, fix, line=None):
        self.issues.append(Issue(path, value, problem, fix, line))


@dataclass
class Number(Spec):
    """A real quantity in SI. ``dim`` is the expected dimension; bounds are in SI."""

    dim: U.Dim = U.DIMENSIONLESS
    min: float | None = None
    max: float | None = None
    min_open: bool = False  # True: value must be > min
    max_open: bool = False  # True: value must be < max
    why: str = ""  # why the bounds are what they are
    integer: bool = False
    #: a bare number is refused (its unit is not evident: g or m/s^2, mm^2/m or m^2/m); the fix
    #: shows `unit_example`
    unit_required: bool = False
    unit_example: str = ""

    def _range_text(self) -> str:
        lo = "" if self.min is None else ("(" if self.min_open else "[") + f"{self.min:g}"
        hi = "" if self.max is None else f"{self.max:g}" + (")" if self.max_open else "]")
        if lo and hi:
            return f"{lo}, {hi}"
        if lo:
            return f"{'>' if self.min_open else '>='} {self.min:g}"
        if hi:
            return f"{'<' if self.max_open else '<='} {self.max:g}"
        return ""

    def check(self, value, path, line, ctx):
        if self.integer:
            if isinstance(value, bool) or not isinstance(value, int):
                ctx.error(path, value, "must be a whole number", f"write an integer {self._range_text()}".strip(), line)
                return None
            x = value
        else:
            if self.unit_required and not isinstance(value, bool):
                try:
                    bare = U.parse_quantity(value, self.dim).unit == ""
                except U.UnitError:
                    bare = False  # said below
                if bare:
                    ctx.error(path, value, "needs its unit: a bare number here is too easily meant in another unit",
                              f"write it with its unit, e.g. {self.unit_example}" if self.unit_example else
                              "write '<number> <unit>'", line)
                    return None
            try:
                x = U.parse_quantity(value, self.dim).value
            except U.UnitError as e:
                unit = U.DIM_NAMES.get(self.dim, "")
                ctx.error(path, value, str(e), f"give a number in SI ({unit}) or '<number> <unit>'", line)
                return None
        if x != x or x in (float("inf"), float("-inf")):
            ctx.error(path, value, "is not a finite number", "give a finite value", line)
            return None
        bad = ((self.min is not None and (x < self.min or (self.min_open and x == self.min)))
               or (self.max is not None and (x > self.max or (self.max_open and x == self.max))))
        if bad:
            rng = self._range_text()
            why = f" ({self.why})" if self.why else ""
            ctx.error(path, value, f"must be {rng}{why}" if rng.startswith(("<", ">")) else
                      f"must lie in {rng}{why}", f"give a value {rng}" if rng.startswith(("<", ">"))
                      else f"give a value in {rng}", line)
            return None
        return x


@dataclass
class Choice(Spec):
    choices: tuple = ()

    def check(self, value, path, line, ctx):
        if value not in self.choices:
            ctx.error(path, value, f"is not one of {', '.join(map(str, self.choices))}",
                      f"use one of: {', '.join(map(str, self.choices))}", line)
            return None
        return value


@dataclass
class Bool(Spec):
    def check(self, value, path, line, ctx):
        if not isinstance(value, bool):
            ctx.error(path, value, "must be true or false", "write true or false", line)
            return None
        return value


@dataclass
class Text(Spec):
    def check(self, value, path, line, ctx):
        if not isinstance(value, str) or not value.strip():
            ctx.error(path, value, "must be a non-empty text", "write a text value", line)
            return None
        return value


@dataclass
class _Items(Spec):
    """A YAML list whose entries share one spec (`item`)."""

    item: Spec = field(default_factory=Number)

    def _entries(self, value: list, path, line, ctx) -> list:
        """Each entry checked by `item` (None where it fails), named path[i] in errors."""
        return [self.item.check(v, f"{path}[{i}]", line, ctx) for i, v in enumerate(value)]


@dataclass
class Tuple(_Items):
    """A fixed-length list of one item spec, e.g. a coordinate range or a point."""

    length: int = 2
    increasing: bool = False

    def check(self, value, path, line, ctx):
        if not isinstance(value, list) or len(value) != self.length:
            ctx.error(path, value, f"must be a list of {self.length} values",
                      f"write [{', '.join(['v'] * self.length)}]", line)
            return None
        out = self._entries(value, path, line, ctx)
        if any(v is None for v in out):
            return None
        if self.increasing and any(b <= a for a, b in zip(out, out[1:], strict=False)):
            ctx.error(path, value, "must be increasing", "put the smaller value first", line)
            return None
        return out


@dataclass
class ListOf(_Items):
    min_length: int = 0
    unique: bool = False

    def check(self, value, path, line, ctx):
        if not isinstance(value, list):
            ctx.error(path, value, "must be a list", "write a YAML list [a, b, ...]", line)
            return None
        if len(value) < self.min_length:
            ctx.error(path, value, f"needs at least {self.min_length} entries", "add entries", line)
            return None
        out = self._entries(value, path, line, ctx)
        if self.unique and len(set(map(repr, value))) != len(value):
            ctx.error(path, value, "has repeated entries", "list each entry once", line)
        return None if any(v is None for v in out) else out


@dataclass
class Section(Spec):
    """A mapping with a fixed set of keys; unknown keys are errors."""

    fields: dict[str, Spec] = field(default_factory=dict)
    checks: list[Callable[[dict, str, LineDict, Context], None]] = field(default_factory=list)

    def check(self, value, path, line, ctx):
        if value is None:
            value = LineDict()
        if not isinstance(value, dict):
            ctx.error(path or "<top>", value, "must be a mapping of keys to values",
                      "write 'key: value' lines indented under it", line)
            return None
        lines = getattr(value, "key_lines", {})
        out: dict[str, Any] = {}
        for key in value:
            if key not in self.fields:
                near = _closest(str(key), self.fields)
                hint = f"did you mean '{near}'? " if near else ""
                ctx.error(_join(path, key), value[key], "is not a known key here",
                          f"{hint}remove it or use one of: {', '.join(self.fields)}", lines.get(key, line))
        ok = True
        for key, spec in self.fields.items():
            p = _join(path, key)
            if key in value:
                v = spec.check(value[key], p, lines.get(key, line), ctx)
                ok &= v is not None
                out[key] = v
            elif spec.required:
                ctx.error(p, _MISSING, "is missing", f"add '{key}:' ({spec.doc})" if spec.doc else f"add '{key}:'",
                          getattr(value, "line", line))
                ok = False
            elif isinstance(spec, Section):
                out[key] = spec.check(None, p, line, ctx)
            elif spec.default is not _MISSING:
                out[key] = spec.default
            else:
                out[key] = None
        if ok:
            for chk in self.checks:
                chk(out, path, value if isinstance(value, LineDict) else LineDict(), ctx)
        return out


@dataclass
class MapOf(Spec):
    """A mapping with free keys (e.g. material names) whose values share one spec."""

    item: Spec = field(default_factory=Section)
    required_keys: tuple = ()

    def check(self, value, path, line, ctx):
        if value is None:
            value = LineDict()
        if not isinstance(value, dict):
            ctx.error(path, value, "must be a mapping", "write 'name:' entries under it", line)
            return None
        lines = getattr(value, "key_lines", {})
        for req in self.required_keys:
            if req not in value:
                ctx.error(_join(path, req), _MISSING, "is missing", f"add an entry '{req}:'", line)
        return {k: self.item.check(v, _join(path, k), lines.get(k, line), ctx) for k, v in value.items()}


@dataclass
class OneOrMap(Spec):
    """One value for every name of `names`, or a mapping of some of them to values (the names left
    out take `absent`): e.g. a setting given once for every condition, or per condition."""

    item: Spec = field(default_factory=Number)
    names: tuple = ()
    absent: Any = None
    example_map: str = ""  # the fix's example of the mapping form
    name_kind: str = "name"  # what the mapping's keys are, in the key reference

    def check(self, value, path, line, ctx):
        if not isinstance(value, dict):
            sub = Context()
            out = self.item.check(value, path, line, sub)
            for i in sub.issues:  # the item's own fix, and the mapping form beside it
                ctx.issues.append(Issue(i.path, i.value, i.problem,
                                        f"{i.fix}, or a mapping {self.example_map}" if self.example_map else i.fix,
                                        i.line))
            return out
        lines = getattr(value, "key_lines", {})
        out: dict[str, Any] = {}
        ok = True
        for k, v in value.items():
            where = lines.get(k, line)
            if k not in self.names:
                near = _closest(str(k), self.names)
                hint = f"did you mean '{near}'? " if near else ""
                ctx.error(_join(path, k), v, f"is not one of {', '.join(self.names)}",
                          f"{hint}name one of: {', '.join(self.names)}", where)
                ok = False
                continue
            x = self.item.check(v, _join(path, k), where, ctx)
            ok &= x is not None
            out[k] = x
        return out if ok else None


def _join(path: str, key) -> str:
    return f"{path}.{key}" if path else str(key)


def _closest(word: str, options) -> str | None:
    import difflib

    m = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return m[0] if m else None


def validate(spec: Section, data, filename: str) -> dict:
    ctx = Context()
    out = spec.check(data, "", getattr(data, "line", 1), ctx)
    if ctx.issues:
        raise CaseError(filename, ctx.issues)
    return out
