"""OpenFOAM dictionaries from Python data, and back.

    text = foam_file({"application": "pimpleFoam", "PIMPLE": {"nCorrectors": 1}}, "controlDict")
    data = parse(text)

Python data -> OpenFOAM text:

    dict             a sub-dictionary          key { ... }      (keys in insertion order)
    list, tuple      a list                    (a b c)          (items: anything below, dicts too)
    bool             a switch                  yes | no
    int              as written                32
    float            repr: the shortest text that reads back as the same double (1e-06, 0.05)
    str              verbatim tokens           Euler, Gauss linear, rhoInf
    Quoted(s)        a string                  "libtqFoam.so"
    Uniform(v)       a uniform field value     uniform 0, uniform (0 0 0)
    Dimensions(...)  dimensions                [0 1 -1 0 0 0 0]

A key is a word (`p`, `div(phi,U)`: balanced parentheses allowed) or, given as Quoted, a regular
expression written in quotes (`"U(Final)?"`, `"end_y(min|max)"`): OpenFOAM matches a quoted key
against the names it looks up. Whether a key is a pattern is never guessed from its characters
(`div((nuEff*dev2(T(grad(U)))))` is a word).

`parse` reads what `foam_file` writes (and plain OpenFOAM dictionaries of the same forms: no
#include, no $macros, no non-uniform fields): words stay str, numbers become int or float,
quoted strings Quoted, `uniform v` Uniform, `[...]` Dimensions, `( ... )` lists, values of
several plain tokens one str joined by single spaces.
"""
from __future__ import annotations

import math
import numbers
import re
from dataclasses import dataclass

#: the column the values start at (OpenFOAM's own writers pad keys to 16)
KEY_WIDTH = 16
INDENT = "    "


class Quoted(str):
    """A string written in double quotes: a string value, or a key that is a regular expression."""


@dataclass(frozen=True)
class Uniform:
    """A uniform field value: `uniform <value>`."""

    value: object


class Dimensions(tuple):
    """Dimension exponents (kg m s K mol A cd): `[0 1 -1 0 0 0 0]`."""


class FoamDictError(ValueError):
    """The data cannot be written as an OpenFOAM dictionary, or the text cannot be read as one."""


_WORD_FORBIDDEN = re.compile(r'[\s";{}/]')


def _key(key) -> str:
    if isinstance(key, Quoted):
        return _quote(key)
    if not isinstance(key, str) or not key:
        raise FoamDictError(f"dictionary key {key!r} is not a non-empty string")
    depth = 0
    for c in key:
        depth += {"(": 1, ")": -1}.get(c, 0)
        if depth < 0:
            break
    if _WORD_FORBIDDEN.search(key) or depth != 0:
        raise FoamDictError(f"dictionary key {key!r} is not an OpenFOAM word; give a regular expression "
                            "as foam_dict.Quoted(...)")
    return key


def _quote(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def value_text(v) -> str:
    """The OpenFOAM text of one value (no trailing ';')."""
    if isinstance(v, Quoted):
        return _quote(v)
    if isinstance(v, Uniform):
        return "uniform " + value_text(v.value)
    if isinstance(v, Dimensions):
        return "[" + " ".join(value_text(x) for x in v) + "]"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        x = float(v)
        if not math.isfinite(x):
            raise FoamDictError(f"{x} cannot be written for OpenFOAM")
        return repr(x)
    if isinstance(v, str):
        if not v.strip() or re.search(r"[;{}\n]", v):
            raise FoamDictError(f"value {v!r}: empty, or ';', braces or a line break in a verbatim value; "
                                "use a dict, a list or Quoted")
        return v
    if isinstance(v, (list, tuple)):
        return "(" + " ".join(value_text(x) for x in v) + ")"
    if isinstance(v, dict):
        return "{ " + inline(v) + " }"
    raise FoamDictError(f"value {v!r} of type {type(v).__name__} cannot be written for OpenFOAM")


def inline(data: dict) -> str:
    """The entries of `data` on one line: `k v; sub { k v; }` (a dictionary's body)."""
    return " ".join(f"{_key(k)} {value_text(v)}" + ("" if isinstance(v, dict) else ";") for k, v in data.items())


def entries(data: dict, indent: str = "") -> list[str]:
    """The lines of the entries of `data` (sub-dictionaries as blocks), each line indented."""
    lines = []
    for k, v in data.items():
        key = _key(k)
        if isinstance(v, dict):
            lines += [indent + key, indent + "{", *entries(v, indent + INDENT), indent + "}"]
        else:
            lines.append(f"{indent}{key.ljust(KEY_WIDTH - 1)} {value_text(v)};")
    return lines


def foam_file(data: dict, object_name: str, cls: str = "dictionary", location: str | None = None,
              note: str | None = None) -> str:
    """A whole OpenFOAM file: the FoamFile header, `note` as // comment lines, then `data`."""
    header = {"version": 2.0, "format": "ascii", "class": cls}
    if location is not None:
        header["location"] = Quoted(location)
    header["object"] = object_name
    lines = entries({"FoamFile": header})
    if note:
        lines += ["// " + line if line else "//" for line in note.splitlines()]
    return "\n".join(lines + [""] + entries(data)) + "\n"


# ------------------------------------------------------------------------------------------------
# Reading
# ------------------------------------------------------------------------------------------------
_PUNCTUATION = "{}()[];"
_INT = re.compile(r"[+-]?\d+")
_REAL = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


def _tokens(text: str) -> list[str]:
    """Strings (with their quotes), punctuation, and words; a word holds balanced parentheses
    (`div(phi,U)`) as OpenFOAM reads it; // and /* */ comments dropped."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if c.isspace():
            i += 1
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            if j >= n:
                raise FoamDictError("unterminated string")
            out.append(text[i:j + 1])
            i = j + 1
        elif text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            if j < 0:
                raise FoamDictError("unterminated /* comment")
            i = j + 2
        elif c in _PUNCTUATION:
            out.append(c)
            i += 1
        else:
            j, depth = i, 0
            while j < n and not (text[j].isspace() or text[j] in '{}[];"'):
                if text[j] == "(":
                    depth += 1
                elif text[j] == ")":
                    if depth == 0:
                        break
                    depth -= 1
                j += 1
            out.append(text[i:j])
            i = j
    return out


def _atom(tok: str):
    if tok.startswith('"'):
        return Quoted(re.sub(r"\\(.)", r"\1", tok[1:-1]))
    if _INT.fullmatch(tok):
        return int(tok)
    if _REAL.fullmatch(tok):
        return float(tok)
    if tok.startswith(("#", "$")):
        raise FoamDictError(f"{tok}: directives and macros are not read")
    return tok


class _Reader:
    def __init__(self, text: str):
        self.toks = _tokens(text)
        self.i = 0

    def next(self) -> str:
        if self.i >= len(self.toks):
            raise FoamDictError("unexpected end of the dictionary")
        self.i += 1
        return self.toks[self.i - 1]

    def dictionary(self, closing: str | None) -> dict:
        out = {}
        while True:
            if self.i >= len(self.toks):
                if closing:
                    raise FoamDictError("a '{' is not closed")
                return out
            tok = self.next()
            if tok == closing:
                return out
            if tok in set(_PUNCTUATION):
                raise FoamDictError(f"unexpected {tok!r} where a key was expected (after {self.toks[:self.i][-6:]})")
            key = _atom(tok) if tok.startswith('"') else tok
            if self.toks[self.i:self.i + 1] == ["{"]:
                self.i += 1
                out[key] = self.dictionary("}")
            else:
                out[key] = self.value()

    def item(self):
        tok = self.next()
        if tok == "(":
            items = []
            while self.toks[self.i:self.i + 1] != [")"]:
                items.append(self.item())
            self.i += 1
            return items
        if tok == "[":
            dims = []
            while (t := self.next()) != "]":
                dims.append(_atom(t))
            return Dimensions(dims)
        if tok == "{":
            return self.dictionary("}")
        if tok == "uniform":
            return Uniform(self.item())
        if tok in {"}", ")", ";", "]"}:
            raise FoamDictError(f"unexpected {tok!r} in a value")
        return _atom(tok)

    def value(self):
        parts = []
        while self.toks[self.i:self.i + 1] != [";"]:
            parts.append(self.item())
        self.i += 1
        if len(parts) == 1:
            return parts[0]
        if not parts or any(isinstance(p, (list, dict, Uniform, Dimensions, Quoted)) for p in parts):
            raise FoamDictError(f"value {parts!r}: only one item, or several plain words and numbers, are read")
        return " ".join(value_text(p) for p in parts)


def parse(text: str) -> dict:
    """The entries of an OpenFOAM dictionary text (the FoamFile header included, as 'FoamFile')."""
    return _Reader(text).dictionary(None)
