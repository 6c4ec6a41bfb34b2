"""Layer 8 — pictures: the paper's figures and the run video from typed results."""
