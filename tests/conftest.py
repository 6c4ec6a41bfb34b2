"""Test-wide settings: headless rendering, no shader cache, deterministic seeds."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")
