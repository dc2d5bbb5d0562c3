"""How far `check`'s run-time estimate moves with its probes alone: the probes measured into an empty
cache again and again, with the product's rounds and with fewer, the two alternated: a benchmark,
not a test.

usage: python -m benchmarks.probe_spread [--case CASE.yaml] [--variant NAME] [--rounds 5]
           [--json FILE]

Each round measures `rates.machine_rates` (the probe, the size class's factor, the thread speed-up on
the threads `run` gives the case, the element-evaluation share where it is subcycled) into an empty
cache file once with the product's settings (`now`) and once with 3 rounds of each and the thread
probe's runs back to back (`few`), in an order that turns each round, and prints the case's
estimate of its shaking (`scene.runtime_estimate`, not corrected by recorded runs) with each
measured figure. A run's estimate moving by much between rounds says that its probes caught the
machine in passing states; on a quiet machine the two settings agree.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from tunnelquake import rates as R
from tunnelquake.case import load_case
from tunnelquake.scene import runtime_estimate

from .common import machine

ROOT = Path(__file__).resolve().parent.parent

#: the former settings, against which the product's are measured
FEW = {"SIZE_ROUNDS": 3, "EVAL_PROBE_ROUNDS": 3, "THREAD_PROBE_ROUNDS": 3, "THREAD_PROBE_GAP_S": 0.0}


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.probe_spread", description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", type=Path, default=ROOT / "cases" / "paper_tunnel" / "case.yaml")
    ap.add_argument("--variant", default=None)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--json", type=Path, default=None, help="write the figures here too")
    a = ap.parse_args(argv)
    if a.rounds < 1:
        raise SystemExit(f"--rounds {a.rounds}: give 1 or more")
    case = load_case(a.case, a.variant)
    now = {k: getattr(R, k) for k in FEW}
    settings = {"now": now, "few": FEW}
    print(f"{machine()}; {a.case} ({a.variant or 'as written'})", flush=True)
    rows = []
    with tempfile.TemporaryDirectory(prefix="tq-probe-spread-") as tmp:
        for r in range(a.rounds):
            for name in ("now", "few") if r % 2 == 0 else ("few", "now"):
                for k, v in settings[name].items():
                    setattr(R, k, v)
                cache = Path(tmp) / f"{name}_{r}.json"
                os.environ["TQ_RATES_FILE"] = str(cache)
                t0 = time.perf_counter()  # the probes, as check's first estimate on a machine runs them
                e = runtime_estimate(case, corrected=False, measure_if_missing=True)
                secs = time.perf_counter() - t0
                (hit,) = json.loads(cache.read_text()).values()
                side = next(iter(hit.get("size_class") or {}), None)
                where = hit["size_class"][side] if side else hit
                row = dict(
                    round=r + 1,
                    setting=name,
                    estimate_s=round(e.wall, 1),  # the conditions as run runs them (side by side where it may)
                    probe_s=hit["probe_s"],
                    size_factor=where.get("factor", 1.0),
                    speedup=where.get("speedup"),
                    eval_share=hit.get("eval_share"),
                    probes_wall_s=round(secs, 1),
                )
                rows.append(row)
                print(json.dumps(row), flush=True)
    for k, v in now.items():
        setattr(R, k, v)
    summary = {}
    for name in settings:
        est = [x["estimate_s"] for x in rows if x["setting"] == name]
        summary[name] = dict(min_s=min(est), median_s=statistics.median(est), max_s=max(est))
        print(
            f"{name}: the estimate {min(est):.1f} to {max(est):.1f} s, median {statistics.median(est):.1f} s "
            f"({settings[name]})"
        )
    if a.json:
        a.json.write_text(
            json.dumps(
                {"machine": machine(), "case": str(a.case), "variant": a.variant, "rows": rows, "summary": summary},
                indent=1,
            )
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
