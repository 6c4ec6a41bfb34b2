"""Find scenario files and load them: the one place that turns a name or path into files.

:func:`find_scenario_files` resolves every way a scenario file is named — nothing (the shipped
ones), a directory, a file path or a bare name (a file stem in ``scenarios/``);
:func:`load_scenario` loads exactly one. Whatever is wrong with a file — missing, unreadable, a
directory, larger than :data:`~fogsim.config.limits.MAX_SCENARIO_FILE_BYTES`, no UTF-8 text, no
TOML, nested too deeply to parse, or breaking the schema — is a
:class:`~fogsim.errors.ScenarioError` naming the file.
"""

from __future__ import annotations

import errno
import os
import stat
import tomllib
from pathlib import Path

from fogsim.config.decode import shown
from fogsim.config.limits import MAX_SCENARIO_FILE_BYTES
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
    mode = _file_mode(candidate)
    if mode is not None and stat.S_ISDIR(mode):
        files = sorted(candidate.glob("*.toml"))
        if not files:
            raise ScenarioError(f"no scenario files (*.toml) in {candidate}")
        return files
    if candidate.suffix != ".toml" and mode is None:
        candidate = SCENARIOS_DIR / f"{source}.toml"
        mode = _file_mode(candidate)
    if mode is None or not stat.S_ISREG(mode):
        names = ", ".join(p.stem for p in sorted(SCENARIOS_DIR.glob("*.toml")))
        raise ScenarioError(
            f"no scenario file {shown(str(source))} (looked at {shown(str(candidate))}); "
            f"known scenarios: {names or '(none)'}"
        )
    return [candidate]


def _file_mode(path: Path) -> int | None:
    """``st_mode`` of what is at ``path`` (links followed), None if nothing can be there.

    Raises:
        ScenarioError: Something is there but cannot be looked at (e.g. no permission).
    """
    try:
        return path.stat().st_mode
    except ValueError:  # a NUL byte: no file has that name
        return None
    except OSError as exc:
        if exc.errno in (errno.ENOENT, errno.ENOTDIR, errno.ENAMETOOLONG, errno.ELOOP):
            return None
        raise ScenarioError(
            f"{shown(str(path))}: cannot look at the scenario path: {exc.strerror or exc}"
        ) from exc


def load_scenario(name_or_path: str | os.PathLike[str]) -> Scenario:
    """Load and validate one scenario by name (file stem in ``scenarios/``) or path.

    Raises:
        ScenarioError: the file is missing, unreadable, too large, no UTF-8 TOML, or breaks the
            contract; a directory is no single scenario.
    """
    mode = _file_mode(Path(name_or_path))
    if mode is not None and stat.S_ISDIR(mode):
        count = len(list(Path(name_or_path).glob("*.toml")))
        raise ScenarioError(
            f"{name_or_path} is a directory of {count} scenario files, not a scenario file; "
            "name one of them"
        )
    (path,) = find_scenario_files(name_or_path)
    return scenario_from_toml(read_scenario_text(path), source=path)


def read_scenario_text(path: Path) -> str:
    """The text of a scenario file, read with a bound on its size.

    Raises:
        ScenarioError: The file cannot be read (the system's reason), is larger than
            :data:`~fogsim.config.limits.MAX_SCENARIO_FILE_BYTES`, or is no UTF-8 text (the
            offset of the first bad byte).
    """
    try:
        with path.open("rb") as stream:
            raw = stream.read(MAX_SCENARIO_FILE_BYTES + 1)
    except OSError as exc:
        raise ScenarioError(
            f"{path}: cannot read the scenario file: {exc.strerror or exc}"
        ) from exc
    if len(raw) > MAX_SCENARIO_FILE_BYTES:
        raise ScenarioError(
            f"{path}: larger than {MAX_SCENARIO_FILE_BYTES} bytes; a scenario file may hold at "
            f"most {MAX_SCENARIO_FILE_BYTES} bytes"
        )
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(
            f"{path}: not UTF-8 text (byte {exc.start} is {raw[exc.start : exc.start + 1]!r}); "
            "a scenario file must be UTF-8 TOML"
        ) from exc


def scenario_from_toml(text: str, source: Path | None = None, where: str | None = None) -> Scenario:
    """Validate the TOML text of a scenario file and build the :class:`Scenario`.

    Args:
        text: The file's text.
        source: The file it came from (kept as ``source_path``, names it in errors).
        where: How errors name the origin if not by ``source`` (e.g. ``recording x.npz``).

    Raises:
        ScenarioError: no valid TOML, nested too deeply for the parser, or the document breaks
            the contract.
    """
    origin = where or (str(source) if source else "scenario")
    try:
        data = tomllib.loads(text)
    except ValueError as exc:  # TOMLDecodeError, or an integer of more than 4300 digits
        raise ScenarioError(f"{origin}: not valid TOML: {exc}") from exc
    except RecursionError as exc:  # tomllib parses nested arrays and tables recursively
        raise ScenarioError(
            f"{origin}: arrays or tables nested too deeply to parse; a scenario nests at "
            "most three levels (objects[0].size)"
        ) from exc
    return scenario_from_dict(data, source=source, where=origin)
