"""Layer 7 — evaluation: the world-fixed archive, metrics against the truth, events, the report."""
