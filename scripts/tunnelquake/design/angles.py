"""The one angle convention of the report: about the tunnel axis from the crown towards +x."""
from __future__ import annotations

import numpy as np


def crown_angle(theta_rad) -> np.ndarray:
    """An angle from +x towards +z (tq-solid's sections) as the report gives every angle: degrees
    from the crown towards +x, in (−180, 180] (springline +x 90°, invert 180°, springline −x −90°)."""
    a = 90.0 - np.degrees(np.asarray(theta_rad, float))
    return -((180.0 - a) % 360.0 - 180.0)
