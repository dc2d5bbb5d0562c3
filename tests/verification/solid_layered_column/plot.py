"""Figure of the two-layer column's transfer function (docs/bench/layered_column.png).

Reads the output of the C++ test with TQ_PRINT_TF=1 on stdin, e.g.

    TQ_PRINT_TF=1 build/tests/cpp/tq_solid_layer_tests \\
        --gtest_filter=LayeredColumn.TwoLayersOnRockMatchTheClosedFormTransferFunction \\
      | python tests/verification/solid_layered_column/plot.py docs/bench/layered_column.png

The test prints four runs in turn (undamped at Courant 0.9 and 0.3, damped at 0.9 and 0.3), each
as lines "f <Hz> |model| <value> |exact| <value>"; the figure shows the Courant 0.9 runs.
"""
from __future__ import annotations

import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(out: str) -> None:
    rows = [tuple(map(float, m.groups())) for m in
            (re.match(r"\s*f\s+(\S+)\s+\|model\|\s+(\S+)\s+\|exact\|\s+(\S+)", line) for line in sys.stdin) if m]
    data = np.array(rows)
    n = len(data) // 4
    runs = {"undamped": data[:n], "mass-proportional 5 % at 1.5 Hz": data[2 * n:3 * n]}
    fig, (ax, ex) = plt.subplots(2, 1, figsize=(7, 6), sharex=True, gridspec_kw={"height_ratios": [3, 1.4]})
    for (label, d), colour in zip(runs.items(), ("C0", "C1"), strict=True):
        ax.plot(d[:, 0], d[:, 2], "-", color=colour, lw=1.2, label=f"closed form, {label}")
        ax.plot(d[:, 0], d[:, 1], "--", color="k" if colour == "C0" else "0.4", lw=0.9,
                label=f"FreeFieldColumn, {label}")
        ex.plot(d[:, 0], 100 * (d[:, 1] / d[:, 2] - 1), color=colour, lw=1.0)
    ax.set_ylabel("|u_surface / u_incident|")
    ax.set_title("Two layers on elastic rock, vertical SH (cs 400 / 800 m/s on 1600 m/s)")
    ax.legend(fontsize=8)
    ex.axhline(2, color="r", lw=0.7, ls=":")
    ex.axhline(-2, color="r", lw=0.7, ls=":")
    ex.set_ylabel("error (%)")
    ex.set_xlabel("frequency (Hz)")
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "layered_column.png")
