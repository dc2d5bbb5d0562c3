"""The sections every small tunnel case of the tests writes alike, each written by one function: the
name, the block of rock with its tunnel and the mesh (`tunnel`), a plain section of `key: value` lines
(`section`), the seeded synthetic motion (`synthetic_motion`), a record read from a file
(`record_motion`). What a test is about (its materials, geology, stages, monitors) stays written out
in the test beside them, as case-file text that its edits can replace.

Values are written as YAML reads them: a number or a string as it is ("2.5 m"), a list or tuple as a
flow sequence ([-15.0, 15.0])."""
from __future__ import annotations

import shutil
from pathlib import Path


def _value(v) -> str:
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return str(v)


def section(name: str, **keys) -> str:
    """A block mapping: `name:` and one indented `key: value` line for each of `keys`, in order."""
    return f"{name}:\n" + "".join(f"  {k}: {_value(v)}\n" for k, v in keys.items())


def tunnel(name: str, x_range, y_range, z_range, *, centre_z, radius, lining, centre_x=None,
           description: str | None = None, **mesh) -> str:
    """A case's head: its name (and description), the geometry (the block's ranges, the tunnel's centre,
    excavated radius and lining thickness; tunnel_centre_x only where given) and the mesh section of
    the `mesh` keys (none: the mesh defaults)."""
    head = f"name: {name}\n" + (f"description: {description}\n" if description else "")
    centre = {} if centre_x is None else {"tunnel_centre_x": centre_x}
    geometry = section("geometry", x_range=x_range, y_range=y_range, z_range=z_range, **centre,
                       tunnel_centre_z=centre_z, excavated_radius=radius, lining_thickness=lining)
    return head + geometry + (section("mesh", **mesh) if mesh else "")


def synthetic_motion(pga, vertical_ratio, duration) -> str:
    """The ground_motion section of the seeded synthetic record: its peak, vertical ratio and duration."""
    return section("ground_motion", source="synthetic", pga=pga, vertical_ratio=vertical_ratio,
                   synthetic=f"{{duration: {duration}}}")


def record_motion(file: str, **keys) -> str:
    """The ground_motion section of a two-column record in `file`, with the further `keys` in order."""
    return section("ground_motion", source="file", file=file, format="two_column", **keys)


def small_slice(name: str) -> str:
    """A small elastic slice (a 3 m tunnel with a 0.4 m lining in a 60 m square of rock, 5 m elements),
    bonded, in situ stresses of k = 1: everything but the motion and what the test adds."""
    return tunnel(name, [-30.0, 30.0], [0.0, 1.0], [-30.0, 30.0], centre_x=0.0, centre_z=0.0, radius="3.0 m",
                  lining="0.4 m", mode="slice", max_element_size="5 m", lining_elements_around=16,
                  lining_elements_through=2, near_field_half_width=8.0, near_field_radial_divisions=3) + """\
materials:
  rock: {model: elastic, youngs_modulus: 12 GPa, poisson_ratio: 0.25, density: 2600 kg/m^3}
  lining: {model: elastic, youngs_modulus: 32 GPa, poisson_ratio: 0.2, density: 2500 kg/m^3}
interface: {model: bonded}
in_situ: {kx: 1.0, ky: 1.0}
"""


def ricker_pulse_file(path, fc: float = 2.5, dt: float = 0.004, n: int = 310) -> None:
    """A Ricker pulse of centre frequency `fc` (peak 1 at 1.5/fc s) as a two-column record (t, a)."""
    import numpy as np

    t = np.arange(n) * dt
    a = (np.pi * fc * (t - 1.5 / fc)) ** 2
    np.savetxt(path, np.column_stack([t, (1 - 2 * a) * np.exp(-a)]))


def pulse_case(tmp_path, text: str, edit=lambda s: s):
    """`text` (edited) written as tmp_path/case.yaml beside a Ricker record pulse.txt; its path."""
    import textwrap

    ricker_pulse_file(tmp_path / "pulse.txt")
    p = tmp_path / "case.yaml"
    p.write_text(edit(textwrap.dedent(text)))
    return p


def wave_tunnel(name: str) -> str:
    """A 3D case under a plane SV wave: a 5 m tunnel with a 0.3 m lining, 120 m long in 6 m axial
    elements, its ends plugged with rock (3 layers), rock and lining alike (elastic, E 5 GPa) and
    bonded, the Ricker record pulse.txt (ricker_pulse_file) as the incident wave at 20 deg, undamped,
    shaking only. It ends with the monitors' heading: the test writes its monitors after it."""
    return tunnel(name, [-30.0, 30.0], [0.0, 120.0], [-30.0, 20.0], centre_x=0.0, centre_z=0.0, radius="2.5 m",
                  lining="0.3 m", mode="3d", max_element_size="6 m", lining_elements_around=16,
                  lining_elements_through=1, elements_along_axis=20, near_field_half_width="7 m",
                  near_field_radial_divisions=2, water_ring_divisions=1, tunnel_end_plugs=3) + """materials:
  rock: {model: elastic, youngs_modulus: 5 GPa, poisson_ratio: 0.3, density: 2300 kg/m^3}
  lining: {model: elastic, youngs_modulus: 5 GPa, poisson_ratio: 0.3, density: 2300 kg/m^3}
interface: {model: bonded}
""" + record_motion("pulse.txt", units="m/s^2", pga="1.0 m/s^2", vertical_ratio=0, cutoff_frequency="12 Hz",
                    baseline_correction="false", convention="incident") + """incident_wave:
  type: SV
  angle: 20
  azimuth: 0
stages: {sequence: [seismic]}
conditions: [no_water]
damping: {ratio: 0}
output:
  monitors:
"""


def short_example(example: Path, folder: Path, duration: str, extra: str = "") -> Path:
    """A copy of an example case's files (not its results) in `folder`, its 10 s of shaking cut to
    `duration` and `extra` appended to its case.yaml; returns `folder`."""
    for f in example.iterdir():
        if f.is_file():
            shutil.copy(f, folder / f.name)
    text = (folder / "case.yaml").read_text()
    assert "  duration: 10 s\n" in text
    (folder / "case.yaml").write_text(text.replace("  duration: 10 s\n", f"  duration: {duration}\n") + extra)
    return folder
