"""tunnelquake mesh: build the all-hex gmsh mesh of the case -> mesh.h5 (rock, lining) + water.msh."""
from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

from .common import DiskFull, atomic_path, folder_held, load_or_report, parser, say


def mesh_dir(case) -> Path:
    return case.output_dir / "mesh"


def _fingerprint(case) -> str:
    from ..case import ground_layers

    d = {"geometry": case.data["geometry"], "mesh": case.data["mesh"]}
    if ground_layers(case.data):  # only then, so that the meshes of cases without layers stay current
        d["layers"] = ground_layers(case.data)
    return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]


def make_mesh(case, force: bool = False) -> dict:
    """Build the mesh unless an up-to-date one (same geometry and mesh keys) is already there."""
    from ..meshing import build_tunnel_mesh, format_summary

    out = mesh_dir(case)
    stamp = out / "fingerprint.json"
    fp = _fingerprint(case)
    if not force and stamp.is_file():
        old = json.loads(stamp.read_text())
        if old.get("fingerprint") == fp and (out / "mesh.h5").is_file():
            say(f"mesh: up to date in {out}")
            return old["summary"]
    out.mkdir(parents=True, exist_ok=True)
    say(f"mesh: building ({case.data['mesh']['mode']}) in {out}")
    from ..case import ground_layers

    stamp.unlink(missing_ok=True)  # the files are up to date only once all three are in place
    summary = build_tunnel_mesh(case.data["geometry"], case.data["mesh"], out, ground_layers(case.data))
    summary = json.loads(json.dumps(summary, default=str))
    with atomic_path(stamp) as tmp:
        tmp.write_text(json.dumps({"fingerprint": fp, "summary": summary}, indent=1))
    for line in format_summary(summary).splitlines():
        say(line)
    return summary


def main(argv: list[str]) -> int:
    p = parser("mesh", __doc__)
    p.add_argument("--force", action="store_true", help="rebuild even when up to date")
    args = p.parse_args(argv)
    case = load_or_report(args.case, args.variant)
    if case is None:
        return 1
    with folder_held(case, "tunnelquake mesh " + " ".join(map(str, argv))) as held:
        if not held:
            return 1
        try:
            make_mesh(case, force=args.force)
        except DiskFull as e:
            print(f"error: {e}", file=sys.stderr)
            return 1
    return 0
