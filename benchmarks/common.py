"""What the benchmarks share: the machine line of a generated table, the observed order of a
ladder, the cheapest run per target accuracy, and the replacement of a marked docs section."""
from __future__ import annotations

import math
import os
import platform
from pathlib import Path

#: target accuracies of the "settings for a target accuracy" tables
TARGETS = (0.05, 0.02, 0.01, 0.005, 0.001)


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


def cheapest_table(ladders, setting, first_column: str = "case", targets: tuple[float, ...] = TARGETS) -> str:
    """For each ladder (.name, .runs, .error_keys) and target accuracy, the cheapest run (wall time)
    whose errors are all within it; setting(ladder, run) names the run. Shared by the solid and the
    water/coupled ladders (fluid.py)."""
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


def update_docs(text: str, new_section: str, begin: str, end: str) -> str:
    """Replace the marked section of a page, or append it when the markers are absent."""
    if begin in text and end in text:
        a = text.index(begin)
        b = text.index(end) + len(end)
        return text[:a] + new_section + text[b:]
    return text.rstrip("\n") + "\n\n" + new_section + "\n"
