"""Quantities with units for the case file.

A value in ``case.yaml`` is either a bare number, taken as SI, or a string ``"<number> <unit>"``
such as ``"8 GPa"``, ``"2.7 g/cm^3"``, ``"37 deg"`` or ``"0.16 g"``. The unit is checked against
the dimension the key expects, so ``E: 8 m`` is an error rather than a silently wrong modulus.

Dimensions are exponent triples of (kg, m, s); angles are dimensionless and converted to degrees
or radians by the key that asks for them.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

STANDARD_GRAVITY = 9.80665  # m/s^2, the 'g' of accelerograms

Dim = tuple[int, int, int]  # exponents of (kg, m, s)

DIMENSIONLESS: Dim = (0, 0, 0)
LENGTH: Dim = (0, 1, 0)
TIME: Dim = (0, 0, 1)
FREQUENCY: Dim = (0, 0, -1)
MASS_DENSITY: Dim = (1, -3, 0)
PRESSURE: Dim = (1, -1, -2)
VELOCITY: Dim = (0, 1, -1)
ACCELERATION: Dim = (0, 1, -2)
DYNAMIC_VISCOSITY: Dim = (1, -1, -1)
STIFFNESS_PER_AREA: Dim = (1, -2, -2)  # Pa/m: a joint's spring per unit area
AREA: Dim = (0, 2, 0)
ANGLE: Dim = DIMENSIONLESS

DIM_NAMES = {
    DIMENSIONLESS: "dimensionless",
    LENGTH: "length (m)",
    TIME: "time (s)",
    FREQUENCY: "frequency (Hz)",
    MASS_DENSITY: "density (kg/m^3)",
    PRESSURE: "stress/pressure (Pa)",
    VELOCITY: "velocity (m/s)",
    ACCELERATION: "acceleration (m/s^2)",
    DYNAMIC_VISCOSITY: "dynamic viscosity (Pa*s)",
    STIFFNESS_PER_AREA: "stiffness per unit area (Pa/m)",
    AREA: "area (m^2)",
}

# unit -> (factor to SI, dimension)
_UNITS: dict[str, tuple[float, Dim]] = {
    "m": (1.0, LENGTH),
    "cm": (1e-2, LENGTH),
    "mm": (1e-3, LENGTH),
    "km": (1e3, LENGTH),
    "s": (1.0, TIME),
    "ms": (1e-3, TIME),
    "min": (60.0, TIME),
    "h": (3600.0, TIME),
    "Hz": (1.0, FREQUENCY),
    "kg": (1.0, (1, 0, 0)),
    "t": (1e3, (1, 0, 0)),
    "N": (1.0, (1, 1, -2)),
    "kN": (1e3, (1, 1, -2)),
    "MN": (1e6, (1, 1, -2)),
    "Pa": (1.0, PRESSURE),
    "kPa": (1e3, PRESSURE),
    "MPa": (1e6, PRESSURE),
    "GPa": (1e9, PRESSURE),
    "bar": (1e5, PRESSURE),
    "deg": (1.0, DIMENSIONLESS),  # angles: the key decides degrees; see parse_angle
    "rad": (180.0 / math.pi, DIMENSIONLESS),
    "gal": (1e-2, ACCELERATION),
    "1": (1.0, DIMENSIONLESS),
    "%": (1e-2, DIMENSIONLESS),
}

_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_QUANTITY = re.compile(rf"^\s*({_NUMBER})\s*(.*?)\s*$")


class UnitError(ValueError):
    """A unit that is unknown or has the wrong dimension; the message says which and why."""


@dataclass(frozen=True)
class Parsed:
    value: float  # in SI (angles in degrees)
    unit: str  # as written ('' for a bare number)


def _unit_factor(unit: str, expected: Dim) -> tuple[float, Dim]:
    """Factor and dimension of a unit expression like 'kg/m^3', 'm/s^2', 'Pa*s', 'g/cm^3'."""
    unit = unit.replace("·", "*").replace("**", "^").replace(" ", "")
    if unit == "g" and expected == ACCELERATION:
        return STANDARD_GRAVITY, ACCELERATION  # accelerograms: g is standard gravity
    factor, dim = 1.0, [0, 0, 0]
    sign = 1
    for token in re.split(r"([*/])", unit):
        if token in ("*", "/"):
            sign = 1 if token == "*" else -1
            continue
        if not token:
            raise UnitError(f"cannot read unit '{unit}'")
        m = re.fullmatch(r"([A-Za-z%]+)(?:\^?([-+]?\d+))?", token)
        if not m:
            raise UnitError(f"cannot read unit '{unit}' (at '{token}')")
        name, exp = m.group(1), int(m.group(2) or 1)
        if name == "g":
            f, d = 1e-3, (1, 0, 0)  # gram, inside a compound such as g/cm^3
        elif name in _UNITS:
            f, d = _UNITS[name]
        else:
            raise UnitError(f"unknown unit '{name}' in '{unit}' (known: {', '.join(sorted(_UNITS))}, g)")
        factor *= f ** (sign * exp)
        for i in range(3):
            dim[i] += sign * exp * d[i]
    return factor, (dim[0], dim[1], dim[2])


def parse_quantity(raw, expected: Dim) -> Parsed:
    """Parse a number (SI) or a '<number> <unit>' string into SI for the expected dimension."""
    if isinstance(raw, bool):
        raise UnitError(f"expected a number, got the boolean {raw!r}")
    if isinstance(raw, (int, float)):
        return Parsed(float(raw), "")
    if not isinstance(raw, str):
        raise UnitError(f"expected a number or a '<number> <unit>' string, got {type(raw).__name__}")
    m = _QUANTITY.match(raw)
    if not m:
        raise UnitError(f"expected a number or '<number> <unit>', got '{raw}'")
    number, unit = float(m.group(1)), m.group(2)
    if not unit:
        return Parsed(number, "")
    factor, dim = _unit_factor(unit, expected)
    if dim != expected:
        raise UnitError(
            f"unit '{unit}' is a {DIM_NAMES.get(dim, str(dim))}, but this key needs a "
            f"{DIM_NAMES.get(expected, str(expected))}"
        )
    return Parsed(number * factor, unit)
