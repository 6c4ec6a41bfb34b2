"""Layer 9 — running: a scenario or a recording end to end, and suites of them."""
