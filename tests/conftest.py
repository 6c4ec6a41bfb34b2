"""Test-wide settings: headless rendering, no shader cache, deterministic seeds."""

import os

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")


@pytest.fixture
def two_scenarios(tmp_path):
    """A folder of two scenarios, ``alpha`` and ``beta`` (the flat floor renamed)."""
    from fogsim.paths import SCENARIOS_DIR  # after the environment above

    folder = tmp_path / "scenarios"
    folder.mkdir()
    text = (SCENARIOS_DIR / "flat_floor.toml").read_text()
    for name in ("alpha", "beta"):
        (folder / f"{name}.toml").write_text(text.replace('"flat_floor"', f'"{name}"'))
    return folder
