"""Locations of the project's data folders."""

from pathlib import Path

PROJECT_ROOT = Path(__file__).resolve().parent.parent
SCENARIOS_DIR = PROJECT_ROOT / "scenarios"
ASSETS_DIR = PROJECT_ROOT / "assets"
