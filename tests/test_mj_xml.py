"""MJCF parsing retried on MuJoCo's spurious 'unknown error in attribute' (fogsim.robot.mj_xml)."""

from __future__ import annotations

import mujoco
import pytest

from fogsim.robot.mj_xml import (
    PARSE_ATTEMPTS,
    model_from_xml_string,
    retry_spurious_parse_error,
)

SPURIOUS = "XML Error: unknown error in attribute 'vertex'\nElement 'mesh', line 20\n"
TETRAHEDRON = (
    '<mujoco><asset><mesh name="m" vertex="0 0 0 1 0 0 0 1 0 0 0 1"/></asset>'
    '<worldbody><geom type="mesh" mesh="m"/></worldbody></mujoco>'
)


class _Loader:
    """Fails with the given messages in turn, then returns a model."""

    def __init__(self, messages: list[str]) -> None:
        self.messages = list(messages)
        self.calls = 0

    def __call__(self) -> mujoco.MjModel:
        self.calls += 1
        if self.messages:
            raise ValueError(self.messages.pop(0))
        return mujoco.MjModel.from_xml_string(TETRAHEDRON)


def test_spurious_error_is_parsed_again() -> None:
    load = _Loader([SPURIOUS])
    model = retry_spurious_parse_error(load)
    assert load.calls == 2
    assert model.nmesh == 1


def test_spurious_error_every_time_is_raised_after_the_attempts() -> None:
    load = _Loader([SPURIOUS] * PARSE_ATTEMPTS)
    with pytest.raises(ValueError, match="unknown error in attribute 'vertex'"):
        retry_spurious_parse_error(load)
    assert load.calls == PARSE_ATTEMPTS


@pytest.mark.parametrize(
    "message",
    [
        "XML Error: bad format in attribute 'vertex'",
        "XML Error: number is too large in attribute 'vertex'",
        "XML Error: Schema violation: unrecognized attribute: 'foo'",
    ],
)
def test_real_errors_are_raised_at_once(message: str) -> None:
    load = _Loader([message])
    with pytest.raises(ValueError, match=message.split(": ", 1)[1].split(" '")[0]):
        retry_spurious_parse_error(load)
    assert load.calls == 1


def test_a_real_fault_in_a_number_is_not_retried() -> None:
    bad = TETRAHEDRON.replace("0 0 1", "0 0 1x")
    with pytest.raises(ValueError, match="bad format in attribute 'vertex'"):
        model_from_xml_string(bad)


def test_model_from_xml_string_compiles_with_and_without_assets() -> None:
    assert model_from_xml_string(TETRAHEDRON).nmesh == 1
    assert model_from_xml_string(TETRAHEDRON, {}).nmesh == 1
