"""Locations of the project's data folders, in a source checkout and in an installed wheel alike.

``scenarios/`` and ``assets/`` live at the top of the repository. A wheel installs them as the
package data folders ``fogsim/scenarios`` and ``fogsim/assets`` (see ``setup.py``); a source
checkout (editable install, or ``PYTHONPATH``) has them beside the package instead.
"""

from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent


def _data_dir(name: str) -> Path:
    """The installed data folder ``fogsim/<name>`` if there is one, else ``<checkout>/<name>``."""
    installed = _PACKAGE_DIR / name
    return installed if installed.is_dir() else _PACKAGE_DIR.parent / name


SCENARIOS_DIR = _data_dir("scenarios")
"""Folder of the shipped scenario files (``*.toml``) and ``baseline.json``."""
HOLDOUT_DIR = SCENARIOS_DIR / "holdout"
"""Folder of the held-out scenarios (``*.toml``): scenes no default was ever tuned on, kept out of
the default suite (``fogsim suite`` reads ``SCENARIOS_DIR``'s own files, not its subfolders) and
run on their own (``fogsim suite scenarios/holdout``) to check that the figures generalise."""
ASSETS_DIR = _data_dir("assets")
"""Folder of the shipped data: MJCF pieces (``mjcf/``) and robot descriptions (``robots/``)."""
ROBOTS_DIR = ASSETS_DIR / "robots"
"""Folder of the robot descriptions, one ``<name>.toml`` per robot."""
ROBOT_NAMES: tuple[str, ...] = tuple(sorted(path.stem for path in ROBOTS_DIR.glob("*.toml")))
"""Names of the shipped robots (their description files' stems), sorted: what ``robot.model``
in a scenario file may name."""
