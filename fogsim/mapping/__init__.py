"""Layer 6 — mapping: the per-frame pipeline from a depth image to the maps (``mapper``)."""
