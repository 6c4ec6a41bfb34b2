"""Layer 1 — configuration: the scenario schema, loading and writing scenario files, run parameters."""
