"""Layer 5 — simulation: the MuJoCo scene, the head camera and the per-frame simulation loop."""
