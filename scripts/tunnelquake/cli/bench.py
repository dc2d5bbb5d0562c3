"""tunnelquake bench: run time against error for the solid verification cases (issue 8).

Runs ladders of settings of the verification cases that have a closed form, each run by
`tq-verification-ladder` (built with the tests; the same case functions as the GoogleTest
verification tests), and writes into FOLDER:

    solid.md       the table (case, setting, error, wall time, observed order) with date and machine
    solid.png      error against wall time, one line per ladder
    solid.json     every run's figures

Ladders (solid):
  wave column SH  mesh: 25, 50, 100, 200 elements over H = 100 m (h = 4 .. 0.5 m), automatic step
  wave column SH  step: 100 elements, Δt = 0.9, 0.45, 0.225, 0.1125 of the critical step
  wave column P   mesh: 25, 50, 100, 200 elements, automatic step
  Kirsch k = 0.5  mesh: 8, 16, 32, 64 elements per quarter (--full: and 128)
  lined tunnel    mesh: 8, 16, 32 elements per quarter, n/4 through the lining (--full: and 64),
                  internal water pressure 1.207 MPa on the prestressed rock's lining, outer at 80 b

--peer adds CalculiX (explicit dynamics) on the same deck in the same session
(tunnelquake.bench_calculix: a 40³ box, 100 increments, alternating 3 times): the ratio of µs per
element-increment and the answer difference go into the generated section; without ccx on PATH
the section says so and why.

--update-docs replaces the part of docs/benchmarks.md between `<!-- bench:solid -->` and
`<!-- /bench:solid -->` (appended if absent) and copies the figure to docs/bench/solid.png.

--stress runs the solid stress tests (tq_solid_stress_tests: time step 0.5-1.2 of the limit, a
60 s 1 g record into a yielding layer, damage to D = 1, distorted elements) and writes their
printed figures to FOLDER/stability.md; with --update-docs, into the `<!-- bench:stress -->`
section of docs/stability.md.
Benchmarks, not tests: wall times are the machine's of the day; the errors are reproducible.
"""
from __future__ import annotations

import argparse
import dataclasses
import datetime as _dt
import json
import math
import os
import platform
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

from .. import bench_calculix
from ..paths import ROOT, build_dir

BEGIN, END = "<!-- bench:solid -->", "<!-- /bench:solid -->"
STRESS_BEGIN, STRESS_END = "<!-- bench:stress -->", "<!-- /bench:stress -->"


@dataclass
class Ladder:
    """One ladder: a case, the setting varied, and its runs (dicts parsed from RESULT lines)."""

    name: str
    setting: str  # "h", "dt" or "n"
    error_keys: tuple[str, ...]
    runs: list[dict] = field(default_factory=list)


def ladder_executable() -> Path:
    return build_dir() / "tests" / "cpp" / "tq-verification-ladder"


def run_case(args: list[str]) -> dict:
    """Run tq-verification-ladder once and return its RESULT line as a dict."""
    exe = ladder_executable()
    if not exe.is_file():
        raise FileNotFoundError(f"{exe} not found: build the tests (cmake --build <build>) or set TQ_BUILD_DIR")
    env = dict(os.environ)
    env.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    env.setdefault("OMP_NUM_THREADS", "1")
    out = subprocess.run([str(exe), *args], capture_output=True, text=True, env=env)
    if out.returncode != 0:
        raise RuntimeError(f"{exe.name} {' '.join(args)} failed ({out.returncode}): {out.stderr.strip()}")
    for line in out.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[len("RESULT "):])
    raise RuntimeError(f"{exe.name} {' '.join(args)} printed no RESULT line")


def observed_orders(sizes: list[float], errors: list[float]) -> list[float | None]:
    """Observed order between successive runs: log(e_i/e_{i+1}) / log(s_i/s_{i+1}); None for the first
    run or where an error is zero or changes sign (no asymptotic pair)."""
    orders: list[float | None] = [None]
    for i in range(1, len(sizes)):
        e0, e1 = errors[i - 1], errors[i]
        if e0 == 0 or e1 == 0 or (e0 > 0) != (e1 > 0) or sizes[i - 1] == sizes[i]:
            orders.append(None)
        else:
            orders.append(math.log(abs(e0 / e1)) / math.log(sizes[i - 1] / sizes[i]))
    return orders


def machine() -> str:
    """The host, its processor and load, for the heading of generated benchmark tables.

    The model name alone is often just "AMD EPYC" on a VM, so the family and model numbers and
    the widest vector extension are added: figures from two different machines are then not
    read as one machine's."""
    cpu = platform.processor() or platform.machine()
    fields: dict[str, str] = {}
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if not line.strip():
                break  # the first processor is enough
            key, _, value = line.partition(":")
            fields.setdefault(key.strip(), value.strip())
    except OSError:
        pass
    if "model name" in fields:
        flags = set(fields.get("flags", "").split())
        vec = "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else "SSE"
        cpu = f"{fields['model name']} (family {fields.get('cpu family', '?')}, model {fields.get('model', '?')}, {vec})"
    load = ""
    if hasattr(os, "getloadavg"):
        load = f", load {os.getloadavg()[0]:.1f} at the end"
    return f"{platform.node()}: {os.cpu_count()} cores, {cpu}, {platform.system()} {platform.release()}{load}"


def ladders(full: bool) -> list[tuple[Ladder, list[list[str]]]]:
    ns = [25, 50, 100, 200]
    kirsch_n = [8, 16, 32, 64] + ([128] if full else [])
    lined_n = [8, 16, 32] + ([64] if full else [])
    return [
        (Ladder("wave column SH, mesh", "h", ("peak_error", "l2_error")),
         [["wave", "--dir", "sh", "--n", str(n)] for n in ns]),
        (Ladder("wave column SH, step (100 elements)", "dt", ("peak_error", "l2_error")),
         [["wave", "--dir", "sh", "--n", "100", "--dt-factor", str(f)] for f in (0.9, 0.45, 0.225, 0.1125)]),
        (Ladder("wave column P, mesh", "h", ("peak_error", "l2_error")),
         [["wave", "--dir", "p", "--n", str(n)] for n in ns]),
        (Ladder("Kirsch k = 0.5, mesh", "n", ("sidewall_error", "crown_error")),
         [["kirsch", "--n", str(n)] for n in kirsch_n]),
        (Ladder("lined tunnel p_i = 1.207 MPa, mesh", "n", ("contact_error", "inner_hoop_error")),
         [["lined", "--n", str(n)] for n in lined_n]),
    ]


def size_of(ladder: Ladder, run: dict) -> float:
    """The refinement variable (falls as the run is refined): h, Δt, or 1/n."""
    return {"h": run.get("h", 0.0), "dt": run.get("dt", 0.0), "n": 1.0 / run.get("n", 1)}[ladder.setting]


def setting_text(ladder: Ladder, run: dict) -> str:
    if ladder.setting == "h":
        return f"h = {run['h']:g} m ({run['n']} el.), Δt = {run['dt']:.3g} s"
    if ladder.setting == "dt":
        return f"Δt = {run['dt_factor']:g} Δt_crit = {run['dt']:.3g} s"
    if "through" in run:
        return f"{run['n']} per quarter, {run['through']} through ({run['elements']} el.)"
    return f"{run['n']} per quarter ({run['elements']} el.)"


def table(done: list[Ladder]) -> str:
    rows = ["| case | setting | steps | error 1 | error 2 | observed order (error 1 / 2) | wall s |",
            "|---|---|---:|---|---|---|---:|"]
    for lad in done:
        sizes = [size_of(lad, r) for r in lad.runs]
        k1, k2 = lad.error_keys
        o1 = observed_orders(sizes, [r[k1] for r in lad.runs])
        o2 = observed_orders(sizes, [r[k2] for r in lad.runs])
        for i, r in enumerate(lad.runs):
            order = "–" if o1[i] is None and o2[i] is None else (
                f"{o1[i]:.2f}" if o1[i] is not None else "–") + " / " + (f"{o2[i]:.2f}" if o2[i] is not None else "–")
            rows.append(f"| {lad.name} | {setting_text(lad, r)} | {r['steps']} | {k1.replace('_error', '')} "
                        f"{100 * r[k1]:+.3f} % | {k2.replace('_error', '')} {100 * r[k2]:+.3f} % | {order} | "
                        f"{r['wall_s']:.2f} |")
    return "\n".join(rows)


TARGETS = (0.05, 0.02, 0.01, 0.005, 0.001)


def cheapest_table(ladders, setting, first_column: str = "case", targets: tuple[float, ...] = TARGETS) -> str:
    """For each ladder (.name, .runs, .error_keys) and target accuracy, the cheapest run (wall time)
    whose errors are all within it; setting(ladder, run) names the run. Shared by the solid and the
    water/coupled ladders (bench_fluid.py)."""
    rows = [f"| {first_column} | " + " | ".join(f"≤ {100 * t:g} %" for t in targets) + " |",
            "|---|" + "---|" * len(targets)]
    for lad in ladders:
        cells = []
        for t in targets:
            ok = [r for r in lad.runs if all(abs(r[k]) <= t for k in lad.error_keys)]
            best = min(ok, key=lambda r: r["wall_s"]) if ok else None
            cells.append(f"{setting(lad, best)}, {best['wall_s']:.2f} s" if best else "not reached")
        rows.append(f"| {lad.name} | " + " | ".join(cells) + " |")
    return "\n".join(rows)


def pick(done: list[Ladder], targets: tuple[float, ...] = TARGETS) -> str:
    """For each solid ladder and target accuracy, the cheapest run whose errors are all within it."""
    return cheapest_table(done, setting_text, "case", targets)


def plot(done: list[Ladder], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5))
    for lad in done:
        for key, style in zip(lad.error_keys, ("-o", "--s"), strict=True):
            t = [r["wall_s"] for r in lad.runs]
            e = [max(abs(r[key]), 1e-9) for r in lad.runs]
            ax.loglog(t, e, style, label=f"{lad.name}: {key.replace('_', ' ')}")
    ax.set_xlabel("wall time per run (s)")
    ax.set_ylabel("|relative error| against the closed form")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title("tq-solid verification cases: error against wall time")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def peer_text(peer: bench_calculix.PeerResult | str | None) -> str:
    """The CalculiX part of the section: the side-by-side table, or why it was not run."""
    head = "**Side by side with CalculiX** (explicit dynamics, same deck, same session; "
    if peer is None:
        return head + "not run: add `--peer`; the last figures are in \"Side by side with CalculiX\" above)."
    if isinstance(peer, str):
        return head + f"skipped: {peer})."
    return (head + "`tunnelquake.bench_calculix`: the P column on a box of 1 m hex8, the deck written by "
            "`tq-solid-bench --write-ccx`; CalculiX's cost per increment from the difference of an N- and an "
            "N/10-increment run):\n\n" + bench_calculix.markdown(peer)
            + "\n\nOn a loaded machine the rounds' ratios scatter: tq-solid's 100 increments take seconds and "
            "CalculiX's run minutes, so the two codes do not see the same load even within a round; compare "
            "with the quiet-machine figures of \"Side by side with CalculiX\" above.")


def section(md_table: str, md_pick: str, command: str, when: str, where: str, figure: str,
            peer: bench_calculix.PeerResult | str | None = None) -> str:
    return f"""{BEGIN}
## Solid verification: error against wall time (issue 8)

`{command}`, {when}, {where}; one thread, `OMP_WAIT_POLICY=PASSIVE`. Each row is one run of the
verification case's own function (`tests/cpp/wave_cases.hpp`, `tunnel_cases.hpp`, the same code as
`WaveColumn.*` and `Kirsch.*`) by `tq-verification-ladder`; errors against the closed forms
(wave column: surface = 2 u0(t − H/c), peak and L2 over the run; Kirsch: wall hoop stress at the
first and last element column, extrapolated to r = b; lined tunnel, `LinedTunnel.*`: the lining
bonded in rock under a uniform internal pressure of 123 m of water, contact pressure and inner
hoop stress of the Lamé fit over the lining elements against the closed form of VERIFICATION.md,
outer boundary at 80 b). Observed order: log(e_i/e_(i+1)) / log(s_i/s_(i+1)) with s = h, Δt or 1/n.
Wall times include building the model (and, for Kirsch, the in-situ and excavation relaxations; for
the lined tunnel the in-situ, excavation, lining and water-pressure relaxations, whose steps the
steps column counts).

{md_table}

![error against wall time]({figure})

**Settings for a target accuracy** (the cheapest run of each ladder with both errors within the
target; wall times of this machine):

{md_pick}

Reading it: the wave column's error is set by the mesh (elements per wavelength of the motion's
highest frequency) and falls at second order; at a fixed mesh a smaller step does not make it
more accurate (lumped mass and the central difference err in opposite directions, and the errors
cancel best near the stable limit: the L2 error grows slightly as Δt falls), it only costs time.
Kirsch's wall stress converges at about second order in the element size around the hole. So
does the lined tunnel's (contact pressure and inner hoop stress: the Lamé fit over centroid
stresses and the polygonal interface are O(h²)); the outer boundary is at 80 b so that the
domain's O((b/L)²) error ((b/L)² = 1.6e-4, against 2.5e-3 at the verification test's 20 b) stays
below the mesh's.

{peer_text(peer)}
{END}"""


def update_docs(text: str, new_section: str, begin: str = BEGIN, end: str = END) -> str:
    """Replace the marked section of a page, or append it when the markers are absent."""
    if begin in text and end in text:
        a = text.index(begin)
        b = text.index(end) + len(end)
        return text[:a] + new_section + text[b:]
    return text.rstrip("\n") + "\n\n" + new_section + "\n"


def stress_executable() -> Path:
    return build_dir() / "tests" / "cpp" / "tq_solid_stress_tests"


def parse_gtest(stdout: str) -> list[dict]:
    """Per test of a GoogleTest run: name, result (OK / FAILED), ms, and the lines it printed."""
    tests: list[dict] = []
    cur: dict | None = None
    for line in stdout.splitlines():
        if line.startswith("[ RUN      ] "):
            cur = {"name": line[13:].strip(), "result": "?", "ms": None, "lines": []}
            tests.append(cur)
        elif cur is not None and (line.startswith("[       OK ] ") or line.startswith("[  FAILED  ] ")):
            cur["result"] = "OK" if "OK" in line[:13] else "FAILED"
            if line.rstrip().endswith(" ms)"):
                cur["ms"] = int(line.rsplit("(", 1)[1].split()[0])
            cur = None
        elif cur is not None and line.strip() and not line.startswith("["):
            cur["lines"].append(line.strip())
    return tests


def stress_section(tests: list[dict], command: str, when: str, where: str) -> str:
    rows = ["| stress test | result | wall s | figures (printed by the test) |", "|---|---|---:|---|"]
    for t in tests:
        figures = "<br>".join(x.replace("|", "\\|") for x in t["lines"] if not x.startswith("/"))
        ms = f"{t['ms'] / 1000:.2f}" if t["ms"] is not None else "–"
        rows.append(f"| `{t['name']}` | {t['result']} | {ms} | {figures} |")
    body = "\n".join(rows)
    return f"""{STRESS_BEGIN}
## Solid stress tests (issue 8): last results

`{command}`, {when}, {where}. The tests are `tests/cpp/test_stability_stress.cpp`
(`tq_solid_stress_tests`, in CI with the other C++ tests: each under a minute); their references
and tolerances are in the file's header and in docs/verification.md. Criterion: each run ends in a
correct result (energy balance within 1 %, D ≤ 1, stresses on the yield surface) or in a clean stop
naming step, quantity and cause, with only finite values in the results file.

{body}
{STRESS_END}"""


def run_stress(args: argparse.Namespace, argv: list[str]) -> int:
    exe = stress_executable()
    if not exe.is_file():
        print(f"tunnelquake bench: {exe} not found: build the tests or set TQ_BUILD_DIR", file=sys.stderr)
        return 1
    env = dict(os.environ)
    env.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    out = subprocess.run([str(exe)], capture_output=True, text=True, env=env)
    tests = parse_gtest(out.stdout)
    when = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    command = "tunnelquake bench " + " ".join(shlex.quote(a) for a in argv)
    text = stress_section(tests, command, when, machine())
    (args.folder / "stability.md").write_text(text + "\n")
    print(text)
    if args.update_docs:
        target = ROOT / "docs" / "stability.md"
        target.write_text(update_docs(target.read_text(), text, STRESS_BEGIN, STRESS_END))
        print(f"updated {target}")
    return 0 if out.returncode == 0 and tests and all(t["result"] == "OK" for t in tests) else 1


def main(argv: list[str]) -> int:
    if "--paper" in argv:  # the paper case's settings (issue 8): scripts/tunnelquake/bench_paper.py
        from ..bench_paper import main as paper_main

        return paper_main([a for a in argv if a != "--paper"])
    if "--identify" in argv:  # the paper's open choices, one at a time: scripts/tunnelquake/paper_study.py
        from ..paper_study import main as identify_main

        return identify_main([a for a in argv if a != "--identify"])
    if "--fluid" in argv:  # water and coupled ladders, stock pimpleFoam ratio: scripts/tunnelquake/bench_fluid.py
        from ..bench_fluid import main as fluid_main

        return fluid_main([a for a in argv if a != "--fluid"])
    p = argparse.ArgumentParser(prog="tunnelquake bench", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("folder", type=Path, help="where solid.md, solid.png and solid.json are written")
    p.add_argument("--full", action="store_true", help="add the long runs (Kirsch 128 per quarter)")
    p.add_argument("--update-docs", action="store_true",
                   help="replace the <!-- bench:solid --> section of docs/benchmarks.md with this run's")
    p.add_argument("--peer", action="store_true",
                   help="also run CalculiX on the same deck (a 40^3 box) and put the ratio into the section")
    p.add_argument("--stress", action="store_true",
                   help="run the solid stress tests instead and write their figures (docs/stability.md section)")
    args = p.parse_args(argv)
    args.folder.mkdir(parents=True, exist_ok=True)
    if args.stress:
        return run_stress(args, argv)
    try:
        done = []
        for lad, runs in ladders(args.full):
            for a in runs:
                r = run_case(a)
                lad.runs.append(r)
                print(f"  {lad.name}: {setting_text(lad, r)}: {lad.error_keys[0]} {100 * r[lad.error_keys[0]]:+.3f} %, "
                      f"{lad.error_keys[1]} {100 * r[lad.error_keys[1]]:+.3f} %, {r['wall_s']:.2f} s", flush=True)
            done.append(lad)
    except (FileNotFoundError, RuntimeError) as e:
        print(f"tunnelquake bench: {e}", file=sys.stderr)
        return 1
    peer: bench_calculix.PeerResult | str | None = None
    if args.peer:
        peer = bench_calculix.missing_reason(build_dir())
        if peer is None:
            print("  CalculiX side by side (40^3 box, 3 alternating repeats) ...", flush=True)
            try:
                peer = bench_calculix.compare(build_dir(), workdir=args.folder / "calculix")
            except bench_calculix.PeerError as e:
                print(f"tunnelquake bench: {e}", file=sys.stderr)
                return 1
        else:
            print(f"  CalculiX side by side skipped: {peer}", flush=True)
    when = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    where = machine()
    command = "tunnelquake bench " + " ".join(shlex.quote(a) for a in argv)
    md = table(done)
    md_pick = pick(done)
    plot(done, args.folder / "solid.png")
    peer_json = dataclasses.asdict(peer) if isinstance(peer, bench_calculix.PeerResult) else peer
    (args.folder / "solid.json").write_text(json.dumps({"date": when, "machine": where, "command": command,
                                                        "ladders": [{"name": d.name, "runs": d.runs} for d in done],
                                                        "peer_calculix": peer_json}, indent=1))
    (args.folder / "solid.md").write_text(section(md, md_pick, command, when, where, "solid.png", peer) + "\n")
    print(md)
    print(md_pick)
    if args.peer:
        print(peer_text(peer))
    if args.update_docs:
        docs = ROOT / "docs"
        (docs / "bench").mkdir(exist_ok=True)
        shutil.copyfile(args.folder / "solid.png", docs / "bench" / "solid.png")
        target = docs / "benchmarks.md"
        target.write_text(update_docs(target.read_text(),
                                      section(md, md_pick, command, when, where, "bench/solid.png", peer)))
        print(f"updated {target} and {docs / 'bench' / 'solid.png'}")
    if isinstance(peer, bench_calculix.PeerResult) and not peer.agree:
        print("tunnelquake bench: tq-solid and CalculiX DISAGREE on the same deck (see the table)", file=sys.stderr)
        return 1
    return 0
