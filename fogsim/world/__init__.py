"""Layer 2 — the world over time: where each object is at a time, and the ground truth it implies."""
