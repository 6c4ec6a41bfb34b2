"""Layer 10 — tuning: searching mapper and segmentation thresholds over replayed recordings."""
