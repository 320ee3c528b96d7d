"""Integrators: the direct-lighting estimator and the Whitted recursion (they own the estimators)."""
