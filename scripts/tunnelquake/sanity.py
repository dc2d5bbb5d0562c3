"""Sanity warnings: inputs far outside the physical range of a rock tunnel, which the schema lets
through (they are valid numbers) but which are far more likely a slip of units or of a digit than
the case meant. Each is a warning, never an error (a study may go there on purpose), naming the key,
the value, the range and why; `tunnelquake check` and `run` print them before anything runs
(docs/user_guide.md "Sanity warnings" lists them).

  PGA above 2 g                  the largest recorded horizontal peaks are about 2-3 g; a record in
                                 cm/s^2 read as g is 981 times too strong
  lining thinner than D/40       hydraulic and traffic linings are D/30 to D/8 (D the excavated
                                 diameter); thinner, the mesh's few elements through it and the
                                 shell reading of its forces both fail
  lining thicker than R/2        a thick-walled cylinder, not a lining: the section forces of the
                                 design check assume a thin shell
  Young's modulus                rock and ground 10 MPa to 150 GPa; a concrete lining 10 to 80 GPa
                                 (a modulus typed in MPa or GPa without its unit is a million or a
                                 thousand times off)
  density                        1,000 to 3,500 kg/m^3 for rock, ground and concrete (g/cm^3 typed
                                 without its unit is 1,000 times off)
  water head above 2,000 m       the highest heads of pressure tunnels and shafts are about 1,800 m
"""
from __future__ import annotations

from .units import STANDARD_GRAVITY

#: the PGA above which a motion is warned of, m/s^2
PGA_MAX = 2.0 * STANDARD_GRAVITY
#: the lining's thickness against the excavated diameter D and radius R
LINING_MIN_OF_DIAMETER = 1.0 / 40.0
LINING_MAX_OF_RADIUS = 0.5
#: Young's modulus ranges, Pa: (ground and rock), (a concrete lining)
E_GROUND = (10e6, 150e9)
E_LINING = (10e9, 80e9)
#: density range of rock, ground and concrete, kg/m^3
DENSITY = (1000.0, 3500.0)
#: the highest water head warned of, m
HEAD_MAX = 2000.0


def pga_warning(key: str, pga: float | None) -> str | None:
    """The warning for a PGA (m/s^2) above PGA_MAX, or None."""
    if pga is None or pga <= PGA_MAX:
        return None
    return (f"{key} {pga:.4g} m/s^2 is {pga / STANDARD_GRAVITY:.3g} g: above {PGA_MAX / STANDARD_GRAVITY:g} g, beyond "
            "the largest peaks recorded (about 2-3 g); check the record's units (cm/s^2 read as g is 981x) and the "
            "scaling")


def _outside(key: str, value: float, lo: float, hi: float, unit: str, why: str) -> str | None:
    if lo <= value <= hi:
        return None
    return f"{key} {value:.4g} {unit} is outside {lo:.4g} to {hi:.4g} {unit}, {why}"


def case_warnings(d: dict) -> list[str]:
    """The sanity warnings of a validated case's data `d` (SI values)."""
    out: list[str | None] = []
    gm = d["ground_motion"]
    out.append(pga_warning("ground_motion.pga", gm["pga"]))
    for key in ("second_horizontal", "vertical"):
        out.append(pga_warning(f"ground_motion.{key}.pga", (gm.get(key) or {}).get("pga")))
    suite = d.get("suite") or {}
    if suite.get("records") is not None:
        out.append(pga_warning("suite.pga", suite.get("pga")))
        for i, r in enumerate(suite["records"]):
            out.append(pga_warning(f"suite.records[{i}].pga", r.get("pga")))
    g = d["geometry"]
    t, r = g["lining_thickness"], g["excavated_radius"]
    if t < LINING_MIN_OF_DIAMETER * 2 * r:
        out.append(f"geometry.lining_thickness {t:g} m is thinner than 1/40 of the excavated diameter {2 * r:g} m "
                   f"({LINING_MIN_OF_DIAMETER * 2 * r:.3g} m): linings are D/30 to D/8; check the value and its unit")
    elif t > LINING_MAX_OF_RADIUS * r:
        out.append(f"geometry.lining_thickness {t:g} m is more than half the excavated radius {r:g} m: a "
                   "thick-walled cylinder, whose section forces the design check (thin shell) does not describe")
    for name, m in d["materials"].items():
        lo, hi = E_LINING if name == "lining" else E_GROUND
        what = "the range of structural concrete" if name == "lining" else "the range of ground and rock"
        out.append(_outside(f"materials.{name}.youngs_modulus", m["youngs_modulus"], lo, hi, "Pa",
                            f"{what}: check its unit (MPa, GPa)"))
        out.append(_outside(f"materials.{name}.density", m["density"], *DENSITY, "kg/m^3",
                            "the range of rock, ground and concrete: check its unit (kg/m^3, not g/cm^3 or t/m^3)"))
    head = (d.get("water") or {}).get("head")
    if head is not None and head > HEAD_MAX and any(c in d["conditions"] for c in ("static_water", "dynamic_water")):
        out.append(f"water.head {head:g} m is above {HEAD_MAX:g} m, higher than the heads of the highest pressure "
                   "tunnels and shafts (about 1,800 m): check the value and its unit")
    return [w for w in out if w is not None]


def member_warnings(members) -> list[str]:
    """The sanity warnings of a record suite's members (their scaled PGAs)."""
    out = []
    for m in members:
        w = pga_warning(f"suite member {m.name} ({m.record.path.name}, scaled by {m.factor:.4g}): PGA", m.pga)
        if w is not None:
            out.append(w)
    return out
