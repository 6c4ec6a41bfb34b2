"""Layer 3 — data: the per-frame contract (:class:`Frame`) and recordings of frames."""
