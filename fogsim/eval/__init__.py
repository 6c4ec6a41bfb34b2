"""Layer 7 — evaluation: archive, metrics, events, pose error, the typed result and report.

Modules: ``archive``, ``metrics``, ``events``, ``maps`` (``maps.npz``), ``pose_error``,
``rounding``, ``result`` and the ``report`` sub-package (schema, build, io, console).
"""
