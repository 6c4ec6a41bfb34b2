"""The names of the depth backends, importable without MuJoCo (the command line's choices)."""

DEPTH_BACKENDS = ("renderer", "raycast")
"""Names of the depth backends: :class:`~fogsim.sim.camera.depth.RendererDepth` (OpenGL) and
:class:`~fogsim.sim.camera.depth.RaycastDepth` (``mujoco.mj_multiRay``)."""
