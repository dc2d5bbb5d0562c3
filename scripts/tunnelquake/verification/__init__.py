"""Verification drivers that run the real solvers on closed-form problems (the coupled ring)."""
