"""Generated scenario files: load_scenario returns a Scenario or raises a ScenarioError naming the
file, in a short message, quickly — never another exception (issue 13, "Parse errors", "Paths from
data", "Resource bounds").

The files: valid documents (every table and key, values inside and just outside their ranges),
the same documents mutated (a value replaced by one of the wrong type or out of range, an unknown
key, a key deleted, a hostile name), valid files with bytes spliced in, binary junk, Latin-1 text
and deeply nested arrays. Hypothesis runs derandomized with a bounded number of examples.
"""

from __future__ import annotations

import datetime
import math
from pathlib import Path

import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fogsim.config import Scenario, load_scenario, scenario_from_toml
from fogsim.config.limits import MAX_EVENTS, MAX_OBJECTS, SCENARIO_NAME
from fogsim.errors import ScenarioError

SETTINGS = settings(
    max_examples=250,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
LONGEST_MESSAGE = 1000
"""Longest message [characters]: values and keys are shown short, whatever the file holds."""

# Values of a wrong type, out of range, not finite, huge, or of TOML's other kinds.
JUNK = st.one_of(
    st.text(max_size=12),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.integers(min_value=16**900, max_value=16**1000),  # past what a message prints
    st.floats(allow_nan=True, allow_infinity=True),
    st.lists(st.integers(-3, 3), max_size=5),
    st.dictionaries(st.text(max_size=4), st.integers(0, 3), max_size=3),
    st.datetimes(min_value=datetime.datetime(1970, 1, 1)),
    st.just("x" * 5000),
)
HOSTILE_NAMES = st.one_of(
    st.sampled_from(["../../x", "/etc/passwd", "..", ".", "a/b", "-rf", ".git", "a..b", ""]),
    st.text(max_size=80),
)
SAFE_NAMES = st.from_regex(r"[A-Za-z0-9][A-Za-z0-9_-]{0,20}", fullmatch=True)


def _number(low: float, high: float) -> st.SearchStrategy[float]:
    """Inside [low, high], one time in 30 just outside it (a document holds many numbers)."""
    span = high - low
    outside = st.sampled_from([low - 0.1 * span - 1e-3, high + 0.1 * span + 1e-3])
    return st.integers(0, 29).flatmap(lambda k: outside if k == 0 else st.floats(low, high))


def _pair(low: float, high: float) -> st.SearchStrategy[list[float]]:
    return st.lists(_number(low, high), min_size=2, max_size=2)


OBJECT_NAMES = st.from_regex(r"[a-z][a-z0-9_]{0,6}", fullmatch=True)
OBJECTS = st.fixed_dictionaries(
    {
        "name": OBJECT_NAMES,
        "center": _pair(-5.0, 5.0),
        "size": st.lists(_number(0.005, 2.0), min_size=3, max_size=3),
    },
    optional={
        "yaw_deg": _number(-360.0, 360.0),
        "base": _number(0.0, 2.0),
        "walkable": st.booleans(),
        "surface": st.sampled_from(["flat", "rough"]),
        "roughness_m": _number(0.002, 0.05),
    },
)
ROUTE_STEPS = st.one_of(
    st.fixed_dictionaries({"walk_to": _pair(-5.0, 5.0)}),
    st.fixed_dictionaries({"turn_to": _number(-720.0, 720.0)}),
    st.fixed_dictionaries({"look": _pair(-90.0, 90.0)}),
    st.fixed_dictionaries({"wait": _number(0.001, 3600.0)}),
)


def _events(names: list[str]) -> st.SearchStrategy[list[dict]]:
    """Events on the objects called ``names`` (on unknown ones if there are none)."""
    target = st.sampled_from(names) if names else OBJECT_NAMES
    event = st.one_of(
        st.fixed_dictionaries({"at": _number(0.0, 100.0), "remove": target}),
        st.fixed_dictionaries(
            {
                "at": _number(0.0, 100.0),
                "move": target,
                "to": _pair(-5.0, 5.0),
                "speed": _number(1e-4, 10.0),
            }
        ),
    )
    return st.lists(event, max_size=2)


TABLES = st.fixed_dictionaries(
    {"name": SAFE_NAMES},
    optional={
        "description": st.text(max_size=30),
        "seed": st.integers(0, 2**32 - 1),
        "frame_rate_hz": _number(0.1, 100.0),
        "robot": st.fixed_dictionaries(
            {},
            optional={"model": st.sampled_from(["icub", "talos"]), "start": _pair(-5.0, 5.0)},
        ),
        "camera": st.fixed_dictionaries(
            {},
            optional={
                "mode": st.sampled_from(["ideal", "depth", "stereo"]),
                "width": st.integers(1, 3000),
                "height": st.integers(1, 3000),
                "fov_deg": _pair(1.0, 170.0),
                "dropout": _number(0.0, 0.9),
                "range_m": _pair(0.01, 100.0).map(sorted),
            },
        ),
        "encoders": st.fixed_dictionaries(
            {}, optional={"bias_deg": _number(0.0, 10.0), "head_noise_deg": _number(0.0, 10.0)}
        ),
        "objects": st.lists(OBJECTS, max_size=4, unique_by=lambda o: o["name"]),
        "route": st.lists(ROUTE_STEPS, max_size=4),
        "mapper": st.fixed_dictionaries(
            {}, optional={"p_occ": _number(0.5, 1.0), "nx": st.integers(-5, 500)}
        ),
        "segmentation": st.fixed_dictionaries(
            {}, optional={"min_plane_pixels": st.integers(0, 50), "correct_tilt": st.booleans()}
        ),
    },
)


@st.composite
def documents(draw: st.DrawFn) -> dict:
    """A scenario document, mostly valid: its events name its objects."""
    document = draw(TABLES)
    if draw(st.booleans()):
        document["events"] = draw(_events([o["name"] for o in document.get("objects", [])]))
    return document


DOCUMENTS = documents()


def _paths(value: object, prefix: tuple = ()) -> list[tuple]:
    """Every key path into a document (tables and arrays), the document itself first."""
    found = [prefix]
    if isinstance(value, dict | list):
        for key, item in value.items() if isinstance(value, dict) else enumerate(value):
            found += _paths(item, (*prefix, key))
    return found


@st.composite
def mutated_documents(draw: st.DrawFn) -> dict:
    """A document with one thing made wrong."""
    document = draw(DOCUMENTS)
    how = draw(st.sampled_from(["replace", "unknown key", "delete", "name", "many"]))
    if how == "name":
        document["name"] = draw(HOSTILE_NAMES)
        return document
    if how == "many":  # past the count limits
        box = {"name": "b", "center": [0.0, 0.0], "size": [0.1, 0.1, 0.1]}
        key, count = draw(st.sampled_from([("objects", MAX_OBJECTS), ("events", MAX_EVENTS)]))
        document["objects"] = [{**box, "name": f"b{i}"} for i in range(count + 1)]
        if key == "events":
            document["events"] = [{"at": float(i), "remove": "b0"} for i in range(count + 1)]
        return document
    path = draw(st.sampled_from(_paths(document)[1:] or [("name",)]))
    *parents, last = path
    target = document
    for key in parents:
        target = target[key]
    if how == "replace":
        target[last] = draw(JUNK)
    elif how == "delete":
        del target[last]
    elif isinstance(target, dict):
        target[draw(st.text(min_size=1, max_size=10))] = draw(JUNK)
    return document


def _toml(document: dict) -> bytes:
    return tomli_w.dumps(document).encode()


@st.composite
def spliced(draw: st.DrawFn) -> bytes:
    """A valid file with junk bytes put in somewhere."""
    text = _toml(draw(DOCUMENTS))
    at = draw(st.integers(0, len(text)))
    return text[:at] + draw(st.binary(min_size=1, max_size=8)) + text[at:]


FILES = st.one_of(
    DOCUMENTS.map(_toml),
    mutated_documents().map(_toml),
    spliced(),
    st.binary(max_size=300),
    st.text(max_size=200).map(lambda t: t.encode("latin-1", errors="replace")),
    st.integers(1, 3000).map(lambda depth: f"x = {'[' * depth}{']' * depth}\n".encode()),
)


@pytest.fixture(scope="module")
def scenario_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz") / "generated.toml"


def _check(outcome: Scenario | ScenarioError, origin: str) -> None:
    """A valid scenario within the limits, or an error naming ``origin`` in a short message."""
    if isinstance(outcome, ScenarioError):
        message = str(outcome)
        assert message.startswith(origin), message[:200]
        assert len(message) <= LONGEST_MESSAGE, message[:200]
        return
    assert SCENARIO_NAME.fullmatch(outcome.name)
    assert len(outcome.objects) <= MAX_OBJECTS and len(outcome.events) <= MAX_EVENTS
    assert all(math.isfinite(x) for o in outcome.objects for x in (*o.center, *o.size))
    assert scenario_from_toml(outcome.to_toml()) == outcome  # what loads writes back equal


@SETTINGS
@given(content=FILES)
def test_a_generated_file_loads_or_is_refused_naming_the_file(scenario_file, content):
    scenario_file.write_bytes(content)
    try:
        outcome: Scenario | ScenarioError = load_scenario(scenario_file)
    except ScenarioError as error:
        outcome = error
    _check(outcome, str(scenario_file))


@SETTINGS
@given(document=st.one_of(DOCUMENTS, mutated_documents()))
def test_a_recording_s_embedded_scenario_is_checked_the_same_way(document):
    """A recording stores its scenario as TOML text, decoded by ``scenario_from_toml``."""
    where = "recording generated.npz"
    try:
        outcome: Scenario | ScenarioError = scenario_from_toml(tomli_w.dumps(document), where=where)
    except ScenarioError as error:
        outcome = error
    _check(outcome, where)
