"""MJCF parsing retried on MuJoCo's spurious parse error; binary mesh and height-field files."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from fogsim.robot.mj_xml import (
    PARSE_ATTEMPTS,
    hfield_file,
    mesh_file,
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


# Doubles that float32 cannot hold (MuJoCo rounds text and files alike), a face order that is
# no permutation of the vertex order, texture coordinates in metres.
VERTICES = np.array([[0.1, 0.0, 0.0], [1.0 / 3.0, 0.7, 0.0], [0.0, 0.2, 0.3], [0.45, 0.35, 0.9]])
FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
TEXCOORDS = np.array([[0.0, 0.0], [0.5, 0.1], [0.25, 1.0 / 3.0], [1.0, 0.75]])
ELEVATION = np.array([[0.2, 0.9, 0.4, 0.3], [0.8, 0.1, 0.65, 0.5], [0.7, 0.35, 0.05, 1.1]])


def _numbers(values) -> str:
    """Text of the numbers as dm_control and fogsim.robot.mjcf write them (round-trip repr)."""
    return " ".join(repr(float(v)) for v in np.ravel(values))


def _model(mesh: str, hfield: str, assets: dict[str, bytes] | None = None) -> mujoco.MjModel:
    """A model of one mesh and one height field, given the attributes of each."""
    return model_from_xml_string(
        f'<mujoco><asset><mesh name="m" {mesh}/><hfield name="h" size="1 0.5 0.2 0.1" {hfield}/>'
        '</asset><worldbody><geom type="mesh" mesh="m"/><geom type="hfield" hfield="h"/>'
        "</worldbody></mujoco>",
        assets,
    )


def test_binary_mesh_and_height_field_compile_as_the_same_numbers_in_text() -> None:
    text = _model(
        f'vertex="{_numbers(VERTICES)}" face="{" ".join(map(str, FACES.ravel()))}" '
        f'texcoord="{_numbers(TEXCOORDS)}"',
        f'nrow="3" ncol="4" elevation="{_numbers(ELEVATION)}"',
    )
    files = _model(
        'file="m.msh"',
        'file="h.bin"',
        {"m.msh": mesh_file(VERTICES, FACES, TEXCOORDS), "h.bin": hfield_file(ELEVATION)},
    )
    for field in ("mesh_vert", "mesh_face", "mesh_texcoord", "mesh_normal", "hfield_data"):
        np.testing.assert_array_equal(getattr(files, field), getattr(text, field), err_msg=field)
    for field in ("geom_pos", "geom_quat", "geom_size", "geom_rbound", "geom_aabb", "body_inertia"):
        np.testing.assert_array_equal(getattr(files, field), getattr(text, field), err_msg=field)
    assert files.mesh_vertnum[0] == 4 and files.mesh_texcoordnum[0] == 4
    # MuJoCo scales heights to [0, 1] (in float32) and keeps the attribute's last row first.
    scaled = ((ELEVATION - ELEVATION.min()) / np.ptp(ELEVATION)).astype(np.float32)
    np.testing.assert_allclose(files.hfield_data.reshape(3, 4), scaled[::-1], rtol=0, atol=3e-7)


def test_binary_files_hold_counts_then_little_endian_arrays() -> None:
    mesh = mesh_file(VERTICES, FACES)  # no texture coordinates
    assert np.frombuffer(mesh[:16], "<i4").tolist() == [4, 0, 0, 4]
    assert len(mesh) == 16 + 4 * 3 * 4 + 4 * 3 * 4
    np.testing.assert_array_equal(np.frombuffer(mesh[16:64], "<f4"), VERTICES.ravel().astype("<f4"))
    np.testing.assert_array_equal(np.frombuffer(mesh[64:], "<i4"), FACES.ravel())
    heights = hfield_file(ELEVATION)
    assert np.frombuffer(heights[:8], "<i4").tolist() == [3, 4] and len(heights) == 8 + 12 * 4
    np.testing.assert_array_equal(np.frombuffer(heights[8:24], "<f4"), ELEVATION[-1].astype("<f4"))
    with pytest.raises(ValueError, match="nrow, ncol"):
        hfield_file(ELEVATION.ravel())
