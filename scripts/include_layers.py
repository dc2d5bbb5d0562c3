"""The include direction of tq-solid's folders (docs/architecture.md "The include direction").

Each folder of solid_solver/src/ and solid_solver/include/tq/ is a layer; a file includes headers of
its own layer or of the layers below it, never of one above:

    elements, materials  <  core  <  contact, boundaries  <  io  <  water, parallel  <  coupling  <  app

(`core/types.hpp`, the scalar types and the error classes, is below them all.) An inversion that is
not fixed yet stands in ALLOWED with what it uses and the move that would remove it; an entry that
no longer matches an include is reported too, so that the list only shrinks. Run by ./Alltest's lint
step:

    python scripts/include_layers.py [--root DIR]     exit 1 listing each inversion
"""
from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

#: the layers, lowest first; folders of one tuple are of the same height and do not include each other
LAYERS = (("elements", "materials"), ("core",), ("contact", "boundaries"), ("io",), ("water", "parallel"),
          ("coupling",), ("app",))
#: headers below every layer
FOUNDATION = {"core/types.hpp"}
#: (file, included header) -> why it is still there and the move that removes it
ALLOWED: dict[tuple[str, str], str] = {}

_INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"', re.M)
_HEIGHT = {folder: h for h, tier in enumerate(LAYERS) for folder in tier}


def _layer_of_include(name: str, own: str) -> tuple[str | None, str]:
    """The layer an include names and the header as `layer/file`: "tq/<layer>/x.hpp" (public),
    "<layer>/x.hpp" (the private src/ root), or a bare name (its own folder). (None, name) for
    headers of other libraries (the coupler: tq/coupler/...)."""
    parts = name.split("/")
    if parts[0] == "tq" and len(parts) >= 3:
        parts = parts[1:]
    if len(parts) >= 2 and parts[0] in _HEIGHT:
        return parts[0], "/".join(parts)
    if len(parts) == 1:
        return own, f"{own}/{name}"
    return None, name


def inversions(root: Path) -> tuple[list[str], list[str]]:
    """(inversions not in ALLOWED, ALLOWED entries that no longer match an include) under root
    (a solid_solver/ folder)."""
    bad, seen = [], set()
    files = [p for base in (root / "src", root / "include" / "tq") if base.is_dir()
             for p in sorted(base.rglob("*")) if p.suffix in (".cpp", ".hpp", ".h", ".inc")]
    for path in files:
        rel = path.relative_to(root).as_posix()
        own = path.relative_to(root / ("src" if rel.startswith("src/") else "include/tq")).parts[0]
        if own not in _HEIGHT:
            if len(path.relative_to(root).parts) > 2:
                bad.append(f"{rel}: its folder {own}/ is in no layer; add it to LAYERS in scripts/include_layers.py")
            continue
        for name in _INCLUDE.findall(path.read_text(errors="replace")):
            layer, header = _layer_of_include(name, own)
            if layer is None or header in FOUNDATION or layer == own:
                continue
            if _HEIGHT[layer] < _HEIGHT[own]:
                continue
            if (rel, header) in ALLOWED:
                seen.add((rel, header))
                continue
            why = "a layer above" if _HEIGHT[layer] > _HEIGHT[own] else "a layer of the same height"
            bad.append(f"{rel}: includes {name} ({layer}/ is {why} {own}/)")
    stale = [f"{f} -> {h}" for f, h in ALLOWED if (f, h) not in seen and (root / f).exists()]
    stale += [f"{f} -> {h} (the file is gone)" for f, h in ALLOWED if not (root / f).exists()]
    return bad, stale


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", type=Path, default=Path(__file__).resolve().parent.parent / "solid_solver",
                    help="the solid_solver/ folder to check")
    a = ap.parse_args(argv)
    bad, stale = inversions(a.root)
    for line in bad:
        print(line)
    if bad:
        print("the includes above go up the layers (" + " < ".join(", ".join(t) for t in LAYERS) + "): move "
              "what they use down, or list them in scripts/include_layers.py ALLOWED with the reason")
    for line in stale:
        print(f"include_layers.py ALLOWED: {line} is no longer included; remove the entry")
    return 1 if bad or stale else 0


if __name__ == "__main__":
    sys.exit(main())
