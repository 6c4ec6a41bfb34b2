"""Find scenario files and load them: the one place that turns a name or path into files.

:func:`find_scenario_files` resolves every way a scenario file is named — nothing (the shipped
ones), a directory, a file path or a bare name (a file stem in ``scenarios/``);
:func:`load_scenario` loads exactly one.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

from fogsim.config.schema import Scenario, scenario_from_dict
from fogsim.errors import ScenarioError
from fogsim.paths import SCENARIOS_DIR


def find_scenario_files(source: str | os.PathLike[str] | None = None) -> list[Path]:
    """The scenario files (``*.toml``) a name or path refers to.

    Args:
        source: None for every shipped scenario; a directory for its ``*.toml`` files; a path
            to one file; or a bare name, the stem of a file in ``scenarios/`` (``"stage"``).

    Returns:
        The files, sorted by name.

    Raises:
        ScenarioError: Nothing is there (the message lists the shipped scenarios) or the
            directory holds no scenario file.
    """
    candidate = Path(SCENARIOS_DIR if source is None else source)
    if candidate.is_dir():
        files = sorted(candidate.glob("*.toml"))
        if not files:
            raise ScenarioError(f"no scenario files (*.toml) in {candidate}")
        return files
    if candidate.suffix != ".toml" and not candidate.exists():
        candidate = SCENARIOS_DIR / f"{source}.toml"
    if not candidate.is_file():
        names = ", ".join(p.stem for p in sorted(SCENARIOS_DIR.glob("*.toml")))
        raise ScenarioError(
            f"no scenario file {str(source)!r} (looked at {candidate}); "
            f"known scenarios: {names or '(none)'}"
        )
    return [candidate]


def load_scenario(name_or_path: str | os.PathLike[str]) -> Scenario:
    """Load and validate one scenario by name (file stem in ``scenarios/``) or path.

    Raises:
        ScenarioError: the file is missing, no valid TOML, or breaks the contract; a directory
            is no single scenario.
    """
    files = find_scenario_files(name_or_path)
    if len(files) != 1:
        raise ScenarioError(
            f"{name_or_path} is a directory of {len(files)} scenario files; name one of them"
        )
    return scenario_from_toml(files[0].read_text(encoding="utf-8"), source=files[0])


def scenario_from_toml(text: str, source: Path | None = None, where: str | None = None) -> Scenario:
    """Validate the TOML text of a scenario file and build the :class:`Scenario`.

    Args:
        text: The file's text.
        source: The file it came from (kept as ``source_path``, names it in errors).
        where: How errors name the origin if not by ``source`` (e.g. ``recording x.npz``).

    Raises:
        ScenarioError: no valid TOML, or the document breaks the contract.
    """
    origin = where or (str(source) if source else "scenario")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{origin}: not valid TOML: {exc}") from exc
    return scenario_from_dict(data, source=source, where=origin)
