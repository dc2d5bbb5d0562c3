"""The period-two amplification of converged implicit windows of several explicit steps, on a model
of one wet node (docs/stability.md "Near-fault pulses", docs/coupler.md "Window force weight").

The model is the adapter's protocol on one degree of freedom: a node of mass m on a spring of
frequency omega (its tie to the rest of the structure), stepped by central differences with the step
h, k steps a window of length D = k h. Step j of a window applies F_w + w_j (F~ - F_w), w_j = 1 - (1 -
j/k) 2 (1 - beta), the last step F~ (tq-solid's FluidCoupling::planStep and exchange). The water is a
pure added mass m_a that answers the window's mean velocity v_w = (u_end - u_start)/D with one
implicit step, F~ = -m_a (v_w - v_(w-1))/D; the window is converged exactly (F~ is the fixed point).
The state (u, v, F_w, v_(w-1)) maps linearly from one window to the next; the largest eigenvalue's
modulus is the amplification a window (above 1: the run diverges).

One-step windows (k = 1) are the monolithic system (m + m_a) a = f - k u and stable at any added
mass, which the model reproduces. With k = 16 and a free node (omega = 0), the linear ramp (beta =
1/2) is unstable from m_a/m = 3.1, beta = 3/4 from 7.6, beta = 7/8 from 28.5, and the end force held
(beta = 1) at none up to 100; with a tie of omega D between about 1 and 3, beta = 3/4 is unstable at
m_a/m = 7.2 (1.10 a window at omega D = 2), beta = 1 is not.

    python -m tunnelquake.verification.window_scheme            # the table of the docs
"""
from __future__ import annotations

import sys

import numpy as np


def window_map(ratio: float, omega_window: float, beta: float, k: int = 16) -> np.ndarray:
    """The 4 x 4 matrix taking (u, v, F_w, v_(w-1)) at a window's start to the next window's start,
    for added mass `ratio` = m_a/m, tie frequency `omega_window` = omega D, window force weight `beta`
    and `k` steps a window (unit mass and window: the map depends on these ratios only)."""
    m, window = 1.0, 1.0
    h = window / k
    stiff = m * (omega_window / window) ** 2
    ma = ratio * m
    weights = [1 - (1 - j / k) * 2 * (1 - beta) for j in range(1, k)] + [1.0]

    def run(x, f_end):
        u, v, f_start, _ = x
        u_start = u
        for w in weights:
            v = v + h * (f_start + w * (f_end - f_start) - stiff * u) / m
            u = u + h * v
        return u, v, u_start

    def step(x):
        ua, _, u_start = run(x, 0.0)
        ub, _, _ = run(x, 1.0)
        a = ma / window
        f_end = -a * ((ua - u_start) / window - x[3]) / (1 + a * (ub - ua) / window)
        u, v, u_start = run(x, f_end)
        return np.array([u, v, f_end, (u - u_start) / window])

    return np.column_stack([step(e) for e in np.eye(4)])


def amplification(ratio: float, omega_window: float, beta: float, k: int = 16) -> float:
    """The largest |eigenvalue| of window_map: the growth a window of the least stable mode."""
    return float(max(abs(np.linalg.eigvals(window_map(ratio, omega_window, beta, k)))))


def limit_ratio(beta: float, k: int = 16, omega_window: float = 0.0, top: float = 100.0) -> float | None:
    """The least added-mass ratio m_a/m (to 1e-3) from which the windows are unstable, or None up to `top`."""
    grid = np.linspace(0.05, top, 2000)
    unstable = [r for r in grid if amplification(r, omega_window, beta, k) > 1 + 1e-9]
    if not unstable:
        return None
    lo, hi = grid[max(0, int(np.searchsorted(grid, unstable[0])) - 1)], unstable[0]
    while hi - lo > 1e-3:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if amplification(mid, omega_window, beta, k) > 1 + 1e-9 else (mid, hi)
    return hi


def main(argv: list[str] | None = None) -> int:
    omegas = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0, 20.0)
    print("| beta | m_a/m | " + " | ".join(f"ωΔ {w:g}" for w in omegas) + " |")
    print("|---|---|" + "---|" * len(omegas))
    for beta in (0.5, 0.75, 1.0):
        for ratio in (3.6, 7.2, 14.4):
            cells = [f"{amplification(ratio, w, beta):.3f}" for w in omegas]
            print(f"| {beta:g} | {ratio:g} | " + " | ".join(f"**{c}**" if float(c) > 1 + 1e-9 else c for c in cells)
                  + " |")
    print()
    for beta in (0.5, 0.75, 0.875, 1.0):
        lim = limit_ratio(beta)
        print(f"beta {beta:g}, free node, 16 steps a window: unstable from m_a/m = "
              f"{'none up to 100' if lim is None else f'{lim:.2f}'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
