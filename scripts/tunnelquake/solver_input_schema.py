"""The layout of solid_input.h5, tq-solid's input: the one table of its groups, attributes and datasets
(its rows in `tunnelquake.solver_input_table`), resolved against the case schema.

Everything else is made from this table:

* `tunnelquake.solid_input` writes the file through :func:`put` (a key not in the table is refused);
* ``python -m tunnelquake.solver_input_schema --write`` generates tq-solid's table
  (solid_solver/src/io/input_schema.inc), whose reader checks every group, attribute, default and
  bound from it, the material parameters' names the material models read by
  (solid_solver/src/materials/parameter_names.hpp) and the reference in docs/formats.md
  "## solid_input.h5"; tests check all three are up to date (tests/python/test_solver_input_schema.py).

An entry linked to a case key (``case="stages.relaxation_tolerance"``) takes its bounds and its
default from the case schema (case.py), unless it states them itself (where tq-solid's default for
an absent attribute is not the case's default).

Material parameters travel with the file: the writer adds the material rows of this table to
``/schema`` and tq-solid checks the material attributes against them, after checking that each
row it was built with is the same in the file. A parameter added here thus reaches tq-solid's
per-region parameter map (``tq-solid --print-input``) without rebuilding it; the other rows are
fixed at build time and their hash (``/schema`` attribute ``hash``) must equal tq-solid's.
"""
from __future__ import annotations

import functools
import hashlib
import json
import math
import sys
from dataclasses import replace

from .paths import ROOT
from .solver_input_table import (  # noqa: F401 - the table's names, used by the writer and the tests
    ENTRIES,
    FORMAT,
    GROUPS,
    MATERIALS,
    MODELS,
    VERSION,
    Entry,
    Group,
    required_by,
)


# ------------------------------------------------------------------------------------------------
# The table, resolved: links to the case schema filled in
# ------------------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=1)
def _case_schema():
    from .case import schema

    return schema()


def _case_spec(dotted: str):
    from .schema import MapOf, OneOrMap, Section

    spec = _case_schema()
    for part in dotted.split("."):
        spec = spec.fields[part]
        if isinstance(spec, MapOf):
            spec = spec.item
        elif isinstance(spec, OneOrMap):  # each value's bounds, the key's default
            spec = replace(spec.item, default=spec.default)
    assert not isinstance(spec, Section), dotted
    return spec


def _resolve(e: Entry) -> Entry:
    if e.case is None:
        return e
    s = _case_spec(e.case)
    kw = {}
    for mine, theirs in (("lo", "min"), ("hi", "max")):
        if getattr(e, mine) is None:
            kw[mine] = getattr(s, theirs, None)
            kw[f"{mine}_open"] = getattr(e, f"{mine}_open") or getattr(s, f"{theirs}_open", False)
    if e.default is None and s.default not in (None, _case_missing()) and not e.choices:
        kw["default"] = float(s.default) if e.kind in ("float", "whole") else s.default
    return replace(e, **kw)


def _case_missing():
    from .schema import _MISSING

    return _MISSING


def entries() -> list[Entry]:
    """The table with the case links resolved (what the writer, tq-solid and the docs use)."""
    return [_resolve(e) for e in ENTRIES]


def linked(group: str, table: list[Entry] | None = None) -> list[Entry]:
    """A group's rows written from a case key (the writer takes them from the case section)."""
    return [e for e in (table or entries()) if e.group == group and e.case]


def lookup(group: str, name: str, table: list[Entry] | None = None) -> Entry:
    for e in table or entries():
        if e.group == group and e.name == name:
            return e
    raise KeyError(f"{group} {name!r} is not in the solid_input.h5 table (scripts/tunnelquake/solver_input_schema.py)")


def _row(e: Entry) -> dict:
    d = {k: getattr(e, k) for k in ("group", "name", "kind", "unit", "default", "lo", "hi", "lo_open", "hi_open",
                                    "required", "choices", "models", "required_by")}
    d["choices"], d["models"], d["required_by"] = list(e.choices), list(e.models), list(e.required_by)
    return d


def schema_hash(table: list[Entry] | None = None) -> str:
    """Hash of every row but the material ones (those travel in the file): 16 hex digits."""
    rows = [_row(e) for e in (table or entries()) if e.group != MATERIALS]
    rows += [{"group": g.path, "members": list(g.members), "required": g.required} for g in GROUPS]
    return hashlib.sha256(json.dumps(rows, sort_keys=True).encode()).hexdigest()[:16]


#: the fields of a material row in /schema material_parameters, in order, joined by "|"
MATERIAL_ROW_FIELDS = ("name", "kind", "unit", "default", "lo", "hi", "lo_open", "hi_open", "required",
                       "choices", "models", "required_by", "case")


def _field_text(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, int | float):
        return repr(float(v))
    if isinstance(v, tuple):
        return ",".join(v)
    return str(v)


def material_rows(table: list[Entry] | None = None) -> list[str]:
    """The material rows as tq-solid reads them from /schema material_parameters: one string a row,
    the fields of MATERIAL_ROW_FIELDS joined by "|" (numbers as Python's repr, flags 0/1, lists by ",")."""
    return ["|".join(_field_text(getattr(e, k)) for k in MATERIAL_ROW_FIELDS)
            for e in (table or entries()) if e.group == MATERIALS]


# ------------------------------------------------------------------------------------------------
# The writer's one entry point
# ------------------------------------------------------------------------------------------------
class SchemaError(ValueError):
    """A value the table refuses (the writer's bug, or a case value outside the solver's range)."""


def put(obj, group: str, name: str, value, table: list[Entry] | None = None) -> None:
    """Write ``value`` as attribute (or dataset) ``name`` of the open h5py group ``obj``, whose
    table group is ``group``; the entry's kind decides the stored type and its bounds are checked."""
    import numpy as np

    e = lookup(group, name, table)
    where = f"solid_input.h5 {group} {name}"
    if e.kind == "data":
        obj[name] = value
        return
    if e.kind in ("str", "names"):
        if not isinstance(value, str):
            raise SchemaError(f"{where}: {value!r} is not a text")
        if e.choices and value not in e.choices:
            raise SchemaError(f"{where}: {value!r} is not one of {', '.join(e.choices)}")
        obj.attrs[name] = value
        return
    x = float(value)
    if not math.isfinite(x):
        raise SchemaError(f"{where}: {value!r} is not finite")
    if (e.lo is not None and (x < e.lo or (e.lo_open and x == e.lo))) or \
            (e.hi is not None and (x > e.hi or (e.hi_open and x == e.hi))):
        raise SchemaError(f"{where}: {value!r} lies outside {_range_text(e)}")
    obj.attrs[name] = np.int64(int(value)) if e.kind == "int" else x


def group_attrs(group: str, values: dict, table: list[Entry] | None = None) -> dict:
    """The attributes the writer puts in ``group`` for ``values`` (attribute name -> value), in the
    table's order: each value as stored (a list for a ``names`` row joined by commas; a dict under
    ``key`` gives attributes ``key_<item>``), less what the group's rows leave out: a value equal to
    the default of an ``omit_default`` row, a ``written_with`` row whose partner is left out, and a
    row with no value. A name that is not an attribute of the group is refused (KeyError)."""
    table = table or entries()
    rows = {e.name: e for e in table if e.group == group}
    given = {}
    for key, value in values.items():
        for name, v in ((f"{key}_{k}", v) for k, v in value.items()) if isinstance(value, dict) else ((key, value),):
            if name not in rows:
                lookup(group, name, table)  # refused: KeyError naming the group and the key
            given[name] = v

    def written(name: str) -> bool:
        e = rows[name]
        return name in given and not (e.omit_default and given[name] == e.default) and \
            (not e.written_with or written(e.written_with))

    return {e.name: _stored(e, given[e.name]) for e in rows.values() if written(e.name)}


def _stored(e: Entry, value):
    if e.kind == "names" and isinstance(value, list | tuple):
        return ",".join(value)
    if e.kind == "int":
        return int(value)
    return float(value) if e.kind in ("float", "whole", "flag") else value


def write_schema(f, table: list[Entry] | None = None) -> None:
    """The /schema group: the hash of the fixed rows and the material rows (tq-solid reads them)."""
    import h5py
    import numpy as np

    g = f.create_group("schema")
    put(g, "/schema", "hash", schema_hash(table), table)
    put(g, "/schema", "material_parameters", np.array(material_rows(table), dtype=h5py.string_dtype()), table)


# ------------------------------------------------------------------------------------------------
# Generated files
# ------------------------------------------------------------------------------------------------
INC = ROOT / "solid_solver" / "src" / "io" / "input_schema.inc"
NAMES = ROOT / "solid_solver" / "src" / "materials" / "parameter_names.hpp"
DOC = ROOT / "docs" / "formats.md"
BEGIN = "<!-- solid_input:begin (generated by python -m tunnelquake.solver_input_schema --write) -->"
END = "<!-- solid_input:end -->"


def _range_text(e: Entry) -> str:
    from .schema import Number

    if e.choices:
        return ", ".join(f"`{c}`" for c in e.choices) if e.kind != "str" or len(e.choices) > 1 else ""
    return Number(min=e.lo, max=e.hi, min_open=e.lo_open, max_open=e.hi_open)._range_text()


def _c_str(s) -> str:
    return json.dumps("" if s is None else str(s), ensure_ascii=False)


def _c_num(x) -> str:
    if x is None:
        return "0"
    return repr(float(x)) if math.isfinite(float(x)) else "0"


_KIND = {"float": "Float", "int": "Int", "whole": "Whole", "flag": "Flag", "str": "Text", "names": "Names",
         "data": "Data"}


def _ident(s: str) -> str:
    return "root" if s == "/" else s.strip("/").replace("/*", "").replace("/", "_")


def cpp_table(table: list[Entry] | None = None) -> str:
    table = table or entries()
    out = ["// solid_input.h5's table for tq-solid: GENERATED by `python -m tunnelquake.solver_input_schema --write`",
           "// from scripts/tunnelquake/solver_input_schema.py; do not edit (a test checks it is up to date).",
           "// Included by input_schema.hpp.", "",
           f"inline constexpr const char* kFormat = {_c_str(FORMAT)};",
           f"inline constexpr int kVersion = {VERSION};",
           f"inline constexpr const char* kHash = {_c_str(schema_hash(table))};",
           f"inline constexpr const char* kMaterials = {_c_str(MATERIALS)};", "",
           "inline constexpr Group kGroups[] = {"]
    for g in GROUPS:
        members = [m for m in g.members] + [e.name for e in table if e.group == g.path and e.kind == "data"]
        out.append(f"    {{{_c_str(g.path)}, {_c_str(','.join(members))}, {'true' if g.required else 'false'}, "
                   f"{_c_str(g.doc)}}},")
    out += ["};", "", "inline constexpr Attr kAttrs[] = {"]
    for e in table:
        d = e.default
        num = isinstance(d, int | float) and not isinstance(d, bool)
        out.append(
            f"    {{{_c_str(e.group)}, {_c_str(e.name)}, Kind::{_KIND[e.kind]}, {_c_str(e.unit)}, "
            f"{'true' if d is not None else 'false'}, {_c_num(d) if num else '0'}, {_c_str(d if not num else '')}, "
            f"{'true' if e.lo is not None else 'false'}, {_c_num(e.lo)}, {'true' if e.lo_open else 'false'}, "
            f"{'true' if e.hi is not None else 'false'}, {_c_num(e.hi)}, {'true' if e.hi_open else 'false'}, "
            f"{'true' if e.required else 'false'}, {_c_str(','.join(e.choices))}, {_c_str(','.join(e.models))}, "
            f"{_c_str(','.join(e.required_by))}, {_c_str(e.case)}}},")
    out += ["};", "", "// One constant per row: the reader names a row by these, never by a string of its own.",
            "namespace key {"]
    groups: dict[str, list[tuple[int, Entry]]] = {}
    for i, e in enumerate(table):
        groups.setdefault(e.group, []).append((i, e))
    for g, rows in groups.items():
        out.append(f"namespace {_ident(g)} {{")
        for i, e in rows:
            out.append(f"inline constexpr const Attr& {e.name} = kAttrs[{i}];")
        out.append(f"}}  // namespace {_ident(g)}")
    out += ["}  // namespace key", ""]
    return "\n".join(out)


def cpp_material_names(table: list[Entry] | None = None) -> str:
    """tq-solid's src/materials/parameter_names.hpp: the names of the material rows, so that the material
    models read their parameters by the table's names without including the reader's table (io/)."""
    table = table or entries()
    out = ["// The material parameters' names in solid_input.h5 (/materials/<region>): GENERATED by",
           "// `python -m tunnelquake.solver_input_schema --write` from scripts/tunnelquake/solver_input_table.py;",
           "// do not edit (a test checks it is up to date). The material models read a region's parameter map",
           "// (MaterialValues) by these; io/input_schema.inc holds the same rows with their bounds, for the reader.",
           "#pragma once", "", "namespace tq::material_parameter {", ""]
    out += [f"inline constexpr const char* {e.name} = {_c_str(e.name)};" for e in table if e.group == MATERIALS]
    out += ["", "}  // namespace tq::material_parameter", ""]
    return "\n".join(out)


def _per_row(texts: list[str]) -> str:
    """One text for a row of several entries: once when all agree, else each, by '/'."""
    return texts[0] if len(set(texts)) == 1 else " / ".join(t or "–" for t in texts)


def _type(e: Entry) -> str:
    k = {"whole": "float (whole)", "flag": "int 0/1", "names": "str (comma-separated)", "data": "dataset"}
    return k.get(e.kind, e.kind) + (f" ({e.unit})" if e.unit else "")


def _default_text(e: Entry) -> str:
    if e.required:
        return "**required**"
    if e.required_by:
        return f"required by {', '.join(e.required_by)}"
    if e.default is None or e.default == "":
        return ""
    return f"`{e.default:g}`" if isinstance(e.default, float) else f"`{e.default}`"


def doc_rows(table: list[Entry] | None = None) -> list[str]:
    table = table or entries()
    rows: list[list[Entry]] = []
    for e in table:
        if e.doc or not rows or rows[-1][0].group != e.group:
            rows.append([e])
        else:
            rows[-1].append(e)
    out = ["| group | attribute (dataset) | type (unit) | default | allowed | meaning |", "|---|---|---|---|---|---|"]
    for r in rows:
        g = r[0].group.replace("*", "<name>") if r[0].group != MATERIALS else "/materials/<region>"
        names = ", ".join(f"`{e.name}`" if e.kind != "data" else f"`{e.name}` (dataset)" for e in r)
        case = ", ".join(f"`{e.case}`" for e in r if e.case)
        doc = r[0].doc + (f" (case key {case})" if case else "")
        cells = [_per_row([f(e) for e in r]) for f in (_type, _default_text, _range_text)]
        out.append(f"| `{g}` | {names} | {' | '.join(cells)} | {doc} |")
    return out


def doc_section(table: list[Entry] | None = None) -> str:
    head = ("The run parameters of `tq-solid`, written by `tunnelquake.solid_input.write_solid_input` (details of "
            "the solver in `docs/solid_solver.md`). SI units. This table is generated from "
            "`scripts/tunnelquake/solver_input_schema.py`, the one table the writer and tq-solid's reader are "
            "made from: a group, attribute or dataset not listed is refused with its path and the allowed names; "
            "a missing required one, a non-finite or out-of-range number or a choice not listed is refused "
            "naming it (exit 2). `/boundary/fixed` holds the supports of the static stages; at the seismic "
            "stage those on the base and the free-field faces become their reactions and the dynamic "
            "boundaries. `tq-solid --print-input FILE` prints what it read, with each region's parameters.")
    import textwrap

    return "\n".join(textwrap.wrap(head, 100) + [""] + doc_rows(table))


def _replace_between(text: str, body: str) -> str:
    start, end = text.index(BEGIN) + len(BEGIN), text.index(END)
    return text[:start] + "\n" + body + "\n" + text[end:]


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if "--write" not in argv:
        print(cpp_table())
        print(doc_section())
        return 0
    INC.write_text(cpp_table())
    NAMES.write_text(cpp_material_names())
    DOC.write_text(_replace_between(DOC.read_text(), doc_section()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
