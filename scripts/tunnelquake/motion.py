"""Ground motions: read records, generate a synthetic one, and process them for input.

Readers
  * PEER AT2 (old 'NPTS=  1559, DT= .02000 SEC' and NGA-West2 'NPTS=  4000, DT=   0.0100 SEC'
    headers, whitespace- or fixed-width-separated values; the units come from the header);
  * plain two-column text (time, acceleration), '#' comments allowed, units given by the caller.

Synthetic motion (used when no record is available; seeded, so repeatable)
  Kanai–Tajimi filtered white noise (Tajimi 1960) under a Jennings et al. (1968) envelope:
  a white-noise ground excitation w(t) drives the soil filter
      x'' + 2 ξg ωg x' + ωg² x = −w(t),   a(t) = −(2 ξg ωg x' + ωg² x),
  and the result is multiplied by e(t) = (t/t1)² for t < t1, 1 for t1 ≤ t ≤ t2,
  exp(−c (t − t2)) after. Defaults: ωg = 2π·2.5 rad/s, ξg = 0.6 (firm ground; Tajimi's values
  for a site like El Centro), t1 = 1.5 s, t2 = 7 s, c = 0.35 1/s, dt = 0.01 s.

Processing (in this order, as the paper: 20 s window, > 20 Hz removed, PGA 1.575 m/s²)
  1. truncate to the window [0, duration];
  2. low-pass: zero-phase 4th-order Butterworth (forward–backward, so no phase shift) at the
     cut-off, when the cut-off is below the record's Nyquist frequency;
  3. baseline correction: remove the mean of the first 0.5 s, then subtract the second derivative
     of the least-squares polynomial a2 t² + a3 t³ fitted to the integrated displacement, so the
     corrected record ends with near-zero velocity and no drift (Boore 2005 style, initial
     conditions kept at rest);
  4. scale the horizontal record to the target PGA; z = vertical_ratio × it (paper: 2/3), or a
     vertical record of its own; a second horizontal record at 90° to the first; the horizontal
     record acts at the azimuth θ from x (across the tunnel) towards y (along its axis):
     x = cos θ h1 − sin θ h2, y = sin θ h1 + cos θ h2;
  5. convention: an 'outcrop' record is twice the incident wave at the base of a half-space, so
     the incident (up-going) motion is half of it; 'incident' takes the record as the incident
     wave itself.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .units import STANDARD_GRAVITY


class MotionError(ValueError):
    """A record that cannot be read; the message names the file, the line and the problem, and
    `fix` (when given) what to do about it."""

    def __init__(self, problem: str, fix: str | None = None, key: str | None = None):
        super().__init__(problem if fix is None else f"{problem}. Fix: {fix}")
        self.problem = problem
        self.fix = fix
        #: the case key the problem is about, when it is not the record itself
        self.key = key


@dataclass
class Record:
    """An acceleration time history in m/s², sampled uniformly from t = 0."""

    dt: float
    acc: np.ndarray  # m/s^2
    name: str = ""
    units_note: str = ""
    source: str = ""  # file path or 'synthetic(...)'

    @property
    def npts(self) -> int:
        return int(self.acc.size)

    @property
    def time(self) -> np.ndarray:
        return np.arange(self.acc.size) * self.dt

    def peak(self) -> tuple[float, float]:
        """(signed peak value in m/s², its time in s)."""
        i = int(np.argmax(np.abs(self.acc)))
        return float(self.acc[i]), i * self.dt


_UNIT_FACTORS = {"g": STANDARD_GRAVITY, "m/s^2": 1.0, "cm/s^2": 0.01, "gal": 0.01}
_NPTS_DT = re.compile(r"NPTS\s*=\s*(\d+)\s*,?\s*DT\s*=\s*([-+0-9.Ee]+)", re.I)
_NPTS_DT_NGA = re.compile(r"^\s*(\d+)\s+([0-9.Ee+-]+)\s+NPTS\s*,\s*DT", re.I)


def _units_from_header(header: list[str]) -> str | None:
    text = " ".join(header).upper()
    if re.search(r"UNITS? (OF|ARE)?\s*\(?G\)?\b", text) or "(G)" in text:
        return "g"
    if "CM/S" in text or "CM/SEC" in text or "GAL" in text:
        return "cm/s^2"
    return None


#: Other places an AT2 file states its step or its point count: the header's words
#: ("1559 points at equal spacing of 0.02 sec") and a PEER-style file name ("..._dt0.02.AT2").
_SPACING_WORDS = re.compile(r"(?:spacing|interval|time step|step)\s+(?:of\s+)?(\d*\.?\d+(?:[Ee][-+]?\d+)?)\s*"
                            r"(?:s|sec|secs|seconds)\b", re.I)
# a total ("1559 points at ..."), not a row's ("8 points across in a row")
_POINTS_WORDS = re.compile(r"\b(\d+)\s+(?:points|values|samples)\s+(?:at|with|sampled|spaced)\b", re.I)
_DT_IN_NAME = re.compile(r"(?:^|[_\-.])dt[_=]?(\d*\.?\d+)(?=[_\-.]|$)", re.I)


def _check_header_step(path: Path, header: list[str], npts: int, dt: float) -> None:
    """Refuse an AT2 file whose 'NPTS=..., DT=...' line disagrees with what the rest of its header,
    or its name, says about the step or the number of points."""
    for k, ln in enumerate(header[:3], start=1):
        if _NPTS_DT.search(ln) or _NPTS_DT_NGA.search(ln):
            continue
        m = _SPACING_WORDS.search(ln)
        if m and not math.isclose(float(m.group(1)), dt, rel_tol=1e-6):
            raise MotionError(f"{path}:4: header says DT={dt:g} s, but line {k} says {m.group(0).strip()!r}: the "
                              "values would be played at the wrong speed",
                              "make DT on line 4 the record's true sampling step")
        m = _POINTS_WORDS.search(ln)
        if m and int(m.group(1)) != npts:
            raise MotionError(f"{path}:4: header says NPTS={npts}, but line {k} says {m.group(1)} points",
                              "make NPTS on line 4 the record's true number of values")
    m = _DT_IN_NAME.search(path.stem)
    if m and not math.isclose(float(m.group(1)), dt, rel_tol=1e-6):
        raise MotionError(f"{path}:4: header says DT={dt:g} s, but the file name says dt {m.group(1)} s: the values "
                          "would be played at the wrong speed",
                          "make DT on line 4 the record's true sampling step (and the file name agree with it)")


def read_at2(path: str | Path, units: str | None = None) -> Record:
    """Read a PEER AT2 acceleration record. ``units`` overrides what the header says."""
    path = Path(path)
    try:
        lines = path.read_text(errors="replace").splitlines()
    except OSError as e:
        raise MotionError(f"{path}: cannot read the record ({e.strerror})") from e
    if len(lines) < 5:
        raise MotionError(f"{path}: an AT2 file has 4 header lines and data; this one has {len(lines)} lines")
    header = lines[:4]
    npts = dt = None
    for ln in header:
        m = _NPTS_DT.search(ln) or _NPTS_DT_NGA.search(ln)
        if m:
            npts, dt = int(m.group(1)), float(m.group(2))
    if npts is None:
        raise MotionError(f"{path}:4: no 'NPTS=..., DT=...' in the first four lines, the AT2 header: is this an AT2 "
                          "record? (set ground_motion.format: two_column for a file of time and acceleration rows)")
    if not dt > 0:
        raise MotionError(f"{path}:4: time step DT={dt} must be positive")
    unit = units or _units_from_header(header)
    if unit is None:
        raise MotionError(f"{path}: the header does not state the units; give them (ground_motion.units)")
    if unit not in _UNIT_FACTORS:
        raise MotionError(f"{path}: unknown units '{unit}' (use one of {', '.join(_UNIT_FACTORS)})")
    _check_header_step(path, header, npts, dt)
    values: list[float] = []
    value_lines: list[int] = []  # the file line of each value, for messages
    per_line = 0  # values on the last full data line (fixed-width files pad the last one with zeros)
    for k, ln in enumerate(lines[4:], start=5):
        if not ln.strip():
            continue
        try:
            row = [float(v) for v in ln.split()]
        except ValueError:
            # fixed-width columns that run together (e.g. 8F10.5 with large negative values)
            try:
                row = [float(ln[i:i + 10]) for i in range(0, len(ln.rstrip()), 10)]
            except ValueError as e:
                raise MotionError(f"{path}:{k}: {_not_a_number(ln)}") from e
        if len(values) < npts:
            per_line = len(row)
        values.extend(row)
        value_lines.extend([k] * len(row))
    length = npts * dt
    if len(values) < npts:
        raise MotionError(f"{path}: header says NPTS={npts}, DT={dt:g} s (a record of {length:g} s) but the file "
                          f"holds {len(values)} values ({len(values) * dt:g} s at that DT)",
                          "correct NPTS in the header (line 4) or restore the missing values")
    extra = values[npts:]
    if extra and not (len(extra) < max(per_line, 2) and all(v == 0.0 for v in extra)):
        raise MotionError(f"{path}:{value_lines[npts]}: header says NPTS={npts}, DT={dt:g} s (a record of "
                          f"{length:g} s) but the file holds {len(values)} values ({len(values) * dt:g} s at that "
                          f"DT); the values from line {value_lines[npts]} on would be dropped",
                          f"correct NPTS (and DT) in the header (line 4) to {len(values)} values, or remove the "
                          "values past NPTS")
    acc = np.asarray(values[:npts]) * _UNIT_FACTORS[unit]
    bad = np.flatnonzero(~np.isfinite(acc))
    if bad.size:
        i = int(bad[0])
        raise MotionError(f"{path}:{value_lines[i]}: value {i + 1} of the record is {values[i]!r}, not a finite "
                          f"number ({bad.size} such value{'s' if bad.size > 1 else ''} in the record)",
                          f"correct or fill in the value on line {value_lines[i]} of the record")
    # Old-style files name the record on line 1; PEER's own files on line 2.
    name = (header[1] if header[0].upper().startswith("PEER") else header[0]).strip() or path.stem
    return Record(dt=dt, acc=acc, name=name, units_note=unit, source=str(path))


def _not_a_number(line: str) -> str:
    """Where a data line stops being numbers, without echoing the line (the file may not be a
    record at all, and its text is not the message's to show)."""
    for i, token in enumerate(line.split("#", 1)[0].replace(",", " ").split(), start=1):
        try:
            float(token)
        except ValueError:
            return (f"field {i} of this line is not a number ({len(token)} characters): is this file a "
                    "ground-motion record?")
    return "this line does not read as numbers: is this file a ground-motion record?"


def read_two_column(path: str | Path, units: str) -> Record:
    """Read 'time acceleration' rows (uniform time step required)."""
    path = Path(path)
    if units not in _UNIT_FACTORS:
        raise MotionError(f"{path}: unknown units '{units}' (use one of {', '.join(_UNIT_FACTORS)})")
    t, a = [], []
    try:
        text = path.read_text(errors="replace")
    except OSError as e:
        raise MotionError(f"{path}: cannot read the record ({e.strerror})") from e
    for k, ln in enumerate(text.splitlines(), start=1):
        s = ln.split("#", 1)[0].replace(",", " ").split()
        if not s:
            continue
        if len(s) != 2:
            raise MotionError(f"{path}:{k}: expected two columns (time, acceleration), got {len(s)}")
        try:
            t.append(float(s[0]))
            a.append(float(s[1]))
        except ValueError as e:
            raise MotionError(f"{path}:{k}: {_not_a_number(ln)}") from e
        if not (math.isfinite(t[-1]) and math.isfinite(a[-1])):
            what = "time" if not math.isfinite(t[-1]) else "acceleration"
            raise MotionError(f"{path}:{k}: the {what} on row {len(t)} is {s[0 if what == 'time' else 1]!r}, not a "
                              "finite number", f"correct or fill in line {k} of the record (or remove that row and "
                              "resample the record to a uniform step)")
    if len(t) < 2:
        raise MotionError(f"{path}: needs at least two rows of (time, acceleration)")
    tt = np.asarray(t)
    steps = np.diff(tt)
    dt = float(np.median(steps))
    if dt <= 0 or np.max(np.abs(steps - dt)) > 1e-6 * max(dt, 1e-12) + 1e-9:
        k = int(np.argmax(np.abs(steps - dt))) + 2
        raise MotionError(f"{path}: time step is not uniform (near data row {k}); resample the record")
    acc = np.asarray(a) * _UNIT_FACTORS[units]
    return Record(dt=dt, acc=acc, name=path.stem, units_note=units, source=str(path))


def read_record(path: str | Path, fmt: str = "auto", units: str | None = None) -> Record:
    """Read a record in 'at2' or 'two_column' format ('auto' looks at the 4th line)."""
    path = Path(path)
    if not path.is_file():
        raise MotionError(f"{path}: file not found")
    if fmt == "auto":
        head = path.read_text(errors="replace").splitlines()[:4]
        fmt = "at2" if path.suffix.lower() == ".at2" or any(_NPTS_DT.search(h) for h in head) else "two_column"
    if fmt == "at2":
        return read_at2(path, units)
    if fmt == "two_column":
        if units is None:
            raise MotionError(f"{path}: a two-column record states no units, and none are given",
                              "give them: ground_motion.units: g, m/s^2, cm/s^2 or gal")
        return read_two_column(path, units)
    raise MotionError(f"unknown record format '{fmt}' (use auto, at2 or two_column)")


# --------------------------------------------------------------------------------------------
# Synthetic motion
# --------------------------------------------------------------------------------------------
@dataclass
class SyntheticModel:
    """Kanai–Tajimi filtered white noise with a Jennings envelope (see the module docstring)."""

    seed: int = 1940
    duration: float = 20.0  # s
    dt: float = 0.01  # s
    ground_frequency: float = 2.5  # Hz, ωg/2π
    ground_damping: float = 0.6  # ξg
    rise_time: float = 1.5  # s, t1
    strong_end: float = 7.0  # s, t2
    decay: float = 0.35  # 1/s, c

    def generate(self) -> Record:
        rng = np.random.default_rng(self.seed)
        n = int(round(self.duration / self.dt)) + 1
        w = rng.standard_normal(n)
        wg, xg = 2 * np.pi * self.ground_frequency, self.ground_damping
        # Exact discrete response of the filter to piecewise-linear forcing is overkill here:
        # integrate with a fine sub-step (RK4, 10 sub-steps) for a smooth, stable filter.
        x = v = 0.0
        out = np.empty(n)
        h = self.dt / 10

        def f(x_, v_, w_):
            return v_, -w_ - 2 * xg * wg * v_ - wg * wg * x_

        for i in range(n):
            out[i] = -(2 * xg * wg * v + wg * wg * x)
            wi = w[i]
            for _ in range(10):
                k1 = f(x, v, wi)
                k2 = f(x + h / 2 * k1[0], v + h / 2 * k1[1], wi)
                k3 = f(x + h / 2 * k2[0], v + h / 2 * k2[1], wi)
                k4 = f(x + h * k3[0], v + h * k3[1], wi)
                x += h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
                v += h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        t = np.arange(n) * self.dt
        env = np.where(t < self.rise_time, (t / self.rise_time) ** 2,
                       np.where(t <= self.strong_end, 1.0, np.exp(-self.decay * (t - self.strong_end))))
        acc = out * env
        acc /= np.max(np.abs(acc))  # unit peak; processing scales it to the target PGA
        return Record(dt=self.dt, acc=acc, name=f"synthetic Kanai-Tajimi seed {self.seed}",
                      units_note="m/s^2", source=f"synthetic(seed={self.seed})")


# --------------------------------------------------------------------------------------------
# Processing
# --------------------------------------------------------------------------------------------
#: the order of the zero-phase Butterworth low-pass (ground_motion.cutoff_frequency)
LOWPASS_ORDER = 4


def lowpass_min_samples(order: int = LOWPASS_ORDER) -> int:
    """The fewest samples the zero-phase low-pass of `order` filters: sosfiltfilt pads each end
    with 3 x (2 sections + 1) samples (its default) and needs more than that."""
    return 3 * (2 * ((order + 1) // 2) + 1) + 1


def lowpass(acc: np.ndarray, dt: float, cutoff: float, order: int = LOWPASS_ORDER) -> np.ndarray:
    """Zero-phase Butterworth low-pass; unchanged when the cut-off is at or above Nyquist."""
    from scipy.signal import butter, sosfiltfilt

    nyq = 0.5 / dt
    if cutoff >= nyq:
        return acc.copy()
    need = lowpass_min_samples(order)
    if len(acc) < need:
        raise MotionError(f"ground_motion: the record keeps {len(acc)} samples (dt = {dt:g} s), too few for the "
                          f"{cutoff:g} Hz zero-phase low-pass, which needs at least {need}",
                          f"give at least {need} samples ({(need - 1) * dt:g} s at this step)")
    sos = butter(order, cutoff / nyq, btype="low", output="sos")
    return sosfiltfilt(sos, acc)


def integrate(acc: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and displacement by the trapezoidal rule (linear acceleration within a step), from
    rest, along the last axis."""
    acc = np.asarray(acc, dtype=float)
    zero = np.zeros(acc.shape[:-1] + (1,))
    vel = np.concatenate([zero, np.cumsum(0.5 * (acc[..., 1:] + acc[..., :-1]) * dt, axis=-1)], axis=-1)
    disp = np.concatenate([zero, np.cumsum(vel[..., :-1] * dt + (acc[..., :-1] / 3 + acc[..., 1:] / 6) * dt * dt,
                                           axis=-1)], axis=-1)
    return vel, disp


def baseline_correct(acc: np.ndarray, dt: float, pre_event: float = 0.5) -> np.ndarray:
    """Remove the pre-event mean and a fitted a2 t² + a3 t³ displacement drift."""
    n0 = max(1, int(round(pre_event / dt)))
    a = acc - np.mean(acc[:n0])
    t = np.arange(a.size) * dt
    _, d = integrate(a, dt)
    basis = np.stack([t**2, t**3], axis=1)
    coef, *_ = np.linalg.lstsq(basis, d, rcond=None)
    return a - (2 * coef[0] + 6 * coef[1] * t)


@dataclass
class ProcessedMotion:
    """The input motion as the solver takes it: incident (up-going) accelerations at the base."""

    dt: float
    ax: np.ndarray  # m/s^2, horizontal across the tunnel (x)
    az: np.ndarray  # m/s^2, vertical
    record: Record
    steps: list[str] = field(default_factory=list)  # what was done, for the log and the report
    convention: str = "outcrop"
    ay: np.ndarray | None = None  # m/s^2, horizontal along the tunnel's axis (y); None: zero

    def __post_init__(self):
        if self.ay is None:
            self.ay = np.zeros_like(self.ax)

    @property
    def time(self) -> np.ndarray:
        return np.arange(self.ax.size) * self.dt


def check_covers(npts: int, dt: float, duration: float | None, source: str) -> None:
    """Refuse a record of `npts` points at `dt` that ends before the window `duration` (s) the case
    asks for: a run would shake for the record's length only. A record lasts NPTS x DT (its last
    sample holds for one step), so one of exactly the window's length passes. `source`: the file,
    or 'synthetic' for the generated motion."""
    if duration is None:
        return
    length = npts * dt
    if duration > length * (1 + 1e-9):
        synthetic = source == "synthetic"
        fix = (f"set ground_motion.synthetic.duration to at least {duration:g} s, or ground_motion.duration to "
               f"{length:g} s or less" if synthetic else
               f"set ground_motion.duration to {length:g} s or less, or give a record at least {duration:g} s long")
        raise MotionError(f"{'the synthetic record' if synthetic else source} lasts {length:g} s ({npts} points at "
                          f"dt = {dt:g} s) but ground_motion.duration is {duration:g} s: the run would shake for "
                          f"{length:g} s only", fix)


def kept_samples(npts: int, dt: float, duration: float | None) -> int:
    """The samples of a record of `npts` at `dt` that the window `duration` keeps (condition())."""
    if duration is not None and duration < (npts - 1) * dt:
        return int(np.floor(duration / dt + 1e-9)) + 1
    return npts


def check_filter_length(npts: int, dt: float, duration: float | None, cutoff: float, source: str) -> None:
    """Refuse a record whose window keeps too few samples for the zero-phase low-pass at `cutoff`
    (none is needed when `cutoff` is at or above the record's Nyquist frequency). The fix named is
    one that applies: a longer window when the record has the samples, else a longer record (a
    longer synthetic one), or a cut-off at the Nyquist frequency, which leaves the record as it is.
    A cut-off below 1 / the window is refused too: it would take out the whole motion (below
    about 1e-7 of the Nyquist frequency the filter's design fails outright)."""
    nyq = 0.5 / dt
    need = lowpass_min_samples()
    kept = kept_samples(npts, dt, duration)
    if cutoff >= nyq:
        return
    if kept >= need:
        window = (kept - 1) * dt
        if cutoff * window < 1.0:
            raise MotionError(f"ground_motion.cutoff_frequency {cutoff:g} Hz is below 1 / the window ({1.0 / window:.3g} "
                              f"Hz for {window:g} s): the low-pass would take out the whole motion",
                              "give the cut-off above the frequencies to keep (15 to 25 Hz for a tunnel's seismic "
                              "response), within what the mesh resolves (`check` warns beyond it)",
                              key="ground_motion.cutoff_frequency")
        return
    synthetic = source == "synthetic"
    what = "the synthetic record" if synthetic else source
    of = f" of its {npts}" if kept < npts else ""
    longest = (need - 1) * dt
    if npts >= need:
        fix = (f"set ground_motion.duration to at least {longest:g} s (the record lasts {npts * dt:g} s), or leave "
               "it out for the whole record")
    elif synthetic:
        fix = (f"set ground_motion.synthetic.duration to at least {longest:g} s, and ground_motion.duration (if "
               "set) to as much")
    else:
        fix = (f"give a record of at least {need} samples ({longest:g} s at dt = {dt:g} s), or set "
               f"ground_motion.cutoff_frequency to {nyq:g} Hz (the record's Nyquist frequency) or more, which "
               "leaves it unfiltered")
    raise MotionError(f"{what}: the window keeps {kept}{of} samples (dt = {dt:g} s), too few for the {cutoff:g} "
                      f"Hz zero-phase low-pass (ground_motion.cutoff_frequency), which needs at least {need}", fix)


def check_window(npts: int, dt: float, duration: float | None, cutoff: float, source: str) -> None:
    """Every test of a record's length that processing it makes (condition()), without reading
    or filtering it: it covers the window `duration`, and the window has the samples the
    low-pass at `cutoff` needs. `tunnelquake check` runs it on each record and suite member,
    `run` on the record it processes. `source`: the file, or 'synthetic'."""
    check_covers(npts, dt, duration, source)
    check_filter_length(npts, dt, duration, cutoff, source)


def check_moves(acc: np.ndarray, dt: float, duration: float | None, source: str) -> None:
    """Refuse a record that is all zeros over the window `duration` when it is to be scaled: it
    cannot be scaled to a PGA (_peak_factor) or a spectrum. Used as recorded it is a run without
    shaking (the hydrostatic state held), which is allowed."""
    if not np.any(np.asarray(acc)[:kept_samples(len(acc), dt, duration)]):
        within = " within ground_motion.duration" if kept_samples(len(acc), dt, duration) < len(acc) else ""
        raise MotionError(f"{source}: the record is all zeros{within}: it cannot be scaled, and shakes nothing",
                          "give the record of the motion meant (or source: none for no horizontal motion)")


def condition(record: Record, *, duration: float | None, cutoff: float, baseline: bool,
              label: str = "") -> tuple[np.ndarray, list[str]]:
    """One record cut to the window, low-passed and baseline-corrected (its own step kept);
    returns the acceleration and what was done."""
    check_window(record.npts, record.dt, duration, cutoff,
                 "synthetic" if record.source.startswith("synthetic(") else record.source)
    steps: list[str] = []
    pre = f"{label}: " if label else ""
    acc = record.acc.astype(float)
    if duration is not None and duration < record.time[-1]:
        acc = acc[: int(np.floor(duration / record.dt + 1e-9)) + 1]
        steps.append(f"{pre}truncated to the first {duration:g} s ({acc.size} points)")
    if cutoff < 0.5 / record.dt:
        acc = lowpass(acc, record.dt, cutoff)
        steps.append(f"{pre}low-pass 4th-order zero-phase Butterworth at {cutoff:g} Hz")
    else:
        steps.append(f"{pre}no filtering needed: the record has no content above its Nyquist "
                     f"{0.5 / record.dt:g} Hz <= cut-off {cutoff:g} Hz")
    if baseline:
        acc = baseline_correct(acc, record.dt)
        steps.append(f"{pre}baseline corrected (pre-event mean, quadratic+cubic displacement drift)")
    return acc, steps


def _peak_factor(acc: np.ndarray, pga: float, source: str) -> float:
    peak = np.max(np.abs(acc))
    if peak <= 0:
        raise MotionError(f"{source}: the record is all zeros; it cannot be scaled to a PGA")
    return pga / peak


def _incident(acc: np.ndarray, convention: str) -> np.ndarray:
    if convention == "outcrop":
        return 0.5 * acc
    if convention == "incident":
        return acc
    raise MotionError(f"unknown convention '{convention}' (use outcrop or incident)")


def _convention_step(convention: str) -> str:
    return ("outcrop record: incident wave = half the record" if convention == "outcrop"
            else "record taken as the incident (up-going) wave")


def process(record: Record, *, duration: float | None, cutoff: float, baseline: bool,
            pga: float | None, vertical_ratio: float, convention: str) -> ProcessedMotion:
    """One horizontal record along x, the vertical `vertical_ratio` times it."""
    acc, steps = condition(record, duration=duration, cutoff=cutoff, baseline=baseline)
    if pga is not None:
        k = _peak_factor(acc, pga, record.source)
        acc = acc * k
        steps.append(f"scaled by {k:.5f} to PGA {pga:g} m/s^2")
    az = vertical_ratio * acc
    steps.append(f"vertical = {vertical_ratio:.4g} x horizontal")
    steps.append(_convention_step(convention))
    return ProcessedMotion(dt=record.dt, ax=_incident(acc, convention), az=_incident(az, convention),
                           record=record, steps=steps, convention=convention)


def _on_clock(acc: np.ndarray, dt: float, dt_to: float, n: int) -> np.ndarray:
    """`acc` sampled at dt, on the clock k dt_to (k < n): linear interpolation, zero past its end."""
    if dt == dt_to and acc.size >= n:
        return acc[:n]
    return np.interp(np.arange(n) * dt_to, np.arange(acc.size) * dt, acc, right=0.0)


def azimuth_cos_sin(degrees: float) -> tuple[float, float]:
    """cos and sin of an azimuth in degrees, exact at multiples of 90 degrees (so that 0 and 90
    give a motion along one axis only, without a 1e-17 share on the other)."""
    q, r = divmod(float(degrees), 90.0)
    if r == 0.0:
        return ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[int(q) % 4]
    t = math.radians(degrees)
    return math.cos(t), math.sin(t)


def along_axis(gm: dict) -> bool:
    """Whether the case's motion has a component along the tunnel's axis (y): a second horizontal
    record, or the horizontal record at an azimuth off the x axis."""
    return gm["second_horizontal"]["file"] is not None or (gm["source"] != "none"
                                                          and azimuth_cos_sin(gm["azimuth"])[1] != 0.0)


#: The further records of a motion: (key, label).
_OTHER_COMPONENTS = (("second_horizontal", "second horizontal"), ("vertical", "vertical"))


def from_case(gm: dict, case_dir: Path) -> tuple[ProcessedMotion, list[str]]:
    """Build the processed input motion from the case's validated `ground_motion` section.

    Three components, each from a record of its own or a rule:
      * the horizontal record h1 (file or synthetic; none for a motion without it) acts at the
        azimuth theta, from x (across the tunnel) towards y (along its axis);
      * a second horizontal record h2 (`second_horizontal`) at theta + 90 degrees;
      * the vertical: a record of its own (`vertical`) or vertical_ratio x h1.
    x = cos theta h1 - sin theta h2, y = sin theta h1 + cos theta h2. `pga` scales h1, and the same
    factor scales a further record (the recorded ratio kept) unless it gives a PGA of its own.
    Further records are put on the clock of h1 (or of the first one given). Returns the motion and
    notes for the user (e.g. that the synthetic fallback was used)."""
    notes: list[str] = []
    opts = {"duration": gm["duration"], "cutoff": gm["cutoff_frequency"], "baseline": gm["baseline_correction"]}
    record = None
    if gm["source"] == "file":
        path = resolve_path(gm["file"], case_dir)
        if path.is_file():
            record = read_record(path, gm["format"], gm["units"])
        elif gm["if_missing"] == "synthetic":
            notes.append(f"ground-motion record {path} is not here: using the synthetic motion "
                         f"(Kanai-Tajimi, seed {gm['synthetic']['seed']}) instead, as the case allows")
        else:
            raise MotionError(f"{path}: file not found")
    if record is None and gm["source"] != "none":
        syn = gm["synthetic"]
        record = SyntheticModel(seed=syn["seed"], duration=syn["duration"], dt=syn["dt"],
                                ground_frequency=syn["ground_frequency"],
                                ground_damping=syn["ground_damping"]).generate()
    c, s = azimuth_cos_sin(gm["azimuth"])
    if all(gm[key]["file"] is None for key, _ in _OTHER_COMPONENTS):  # one record, the vertical a ratio of it
        m = process(record, pga=gm["pga"], vertical_ratio=gm["vertical_ratio"], convention=gm["convention"], **opts)
        if s != 0.0:
            h = m.ax
            m.ax, m.ay = c * h, s * h
            m.steps.insert(-1, f"horizontal record at azimuth {gm['azimuth']:g} deg from x towards y: "
                               f"x = {c:.4g} h, y = {s:.4g} h")
        return m, notes
    steps: list[str] = []
    factor = 1.0
    h1 = None
    if record is not None:
        h1, st = condition(record, label="horizontal", **opts)
        steps += st
        if gm["pga"] is not None:
            factor = _peak_factor(h1, gm["pga"], record.source)
            h1 = h1 * factor
            steps.append(f"horizontal: scaled by {factor:.5f} to PGA {gm['pga']:g} m/s^2")
    others: dict[str, tuple[Record, np.ndarray]] = {}
    for key, label in _OTHER_COMPONENTS:
        spec = gm[key]
        if spec["file"] is None:
            continue
        rec = read_record(resolve_path(spec["file"], case_dir), spec["format"], spec["units"])
        acc, st = condition(rec, label=label, **opts)
        steps += st
        k = _peak_factor(acc, spec["pga"], rec.source) if spec["pga"] is not None else factor
        steps.append(f"{label}: scaled by {k:.5f}" + (f" to PGA {spec['pga']:g} m/s^2" if spec["pga"] is not None
                                                      else " (the horizontal record's factor)"))
        others[key] = (rec, acc * k)
    lead = record if record is not None else next(iter(others.values()))[0]
    n = h1.size if h1 is not None else next(iter(others.values()))[1].size
    if h1 is None:
        h1 = np.zeros(n)
        steps.append("no horizontal record (source: none)")
    on_clock = {}
    for key, label in _OTHER_COMPONENTS:
        if key not in others:
            continue
        rec, acc = others[key]
        if rec.dt != lead.dt:
            steps.append(f"{label}: resampled from dt {rec.dt:g} s to {lead.dt:g} s (linear)")
        on_clock[key] = _on_clock(acc, rec.dt, lead.dt, n)
    h2 = on_clock.get("second_horizontal", np.zeros(n))
    if "vertical" in on_clock:
        v = on_clock["vertical"]
    else:
        ratio = gm["vertical_ratio"] or 0.0  # none with source none: no horizontal record to scale
        v = ratio * h1
        steps.append(f"vertical = {ratio:.4g} x horizontal")
    if (c, s) == (1.0, 0.0) and "second_horizontal" in on_clock:
        steps.append("horizontal record along x (across the tunnel), the second horizontal along y (the axis)")
    elif s != 0.0 or "second_horizontal" in on_clock:
        steps.append(f"horizontal record at azimuth {gm['azimuth']:g} deg from x towards y, the second at 90 deg "
                     f"to it: x = {c:.4g} h1 - {s:.4g} h2, y = {s:.4g} h1 + {c:.4g} h2")
    ax, ay = c * h1 - s * h2, s * h1 + c * h2
    steps.append(_convention_step(gm["convention"]))
    conv = gm["convention"]
    return ProcessedMotion(dt=lead.dt, ax=_incident(ax, conv), az=_incident(v, conv), record=lead, steps=steps,
                           convention=conv, ay=_incident(ay, conv)), notes


def window_seconds(gm: dict, case_dir: Path) -> float | None:
    """The length of the processed motion (the time of its last sample, which a run without
    time.end_time shakes for): ground_motion.duration when set, else that of the record which
    sets the clock (the horizontal one, the synthetic, or the first further record); None when
    that record cannot be read (the case's checks say why)."""
    records = [gm] if gm["source"] == "file" else []
    records += [gm[key] for key, _ in _OTHER_COMPONENTS if gm[key]["file"] is not None]
    length = None
    if gm["source"] == "synthetic" or (gm["source"] == "file" and gm["if_missing"] == "synthetic"
                                       and not resolve_path(gm["file"], case_dir).is_file()):
        syn = gm["synthetic"]
        length = (int(round(syn["duration"] / syn["dt"]))) * syn["dt"]
    else:
        for spec in records:
            try:
                rec = read_record(resolve_path(spec["file"], case_dir), spec["format"], spec["units"])
            except MotionError:
                return None
            length = (rec.npts - 1) * rec.dt
            break
    if length is None:
        return gm["duration"]
    return length if gm["duration"] is None else min(length, gm["duration"])


def resolve_path(p: str, case_dir: Path) -> Path:
    path = Path(p).expanduser()
    return path if path.is_absolute() else (case_dir / path).resolve()
