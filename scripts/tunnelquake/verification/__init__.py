"""Verification drivers that run the real solvers on closed-form problems (issue 6: coupled ring)."""
