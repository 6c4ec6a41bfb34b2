import dataclasses

import pytest

from mapper import InvalidParameterError, MapperParams


def test_defaults_are_the_papers_grid():
    p = MapperParams()
    assert (p.nx, p.ny, p.nz) == (100, 100, 16)
    assert p.cell_m == pytest.approx(0.04) and p.layer_m == pytest.approx(0.04)
    assert p.extent_x_m == pytest.approx(4.0) and p.extent_y_m == pytest.approx(4.0)
    # ground z=0 in the middle of layer 1, top of the grid at 0.58 m
    assert p.z_min_m == pytest.approx(-0.06)
    assert p.z_max_m == pytest.approx(0.58)
    assert p.cell_count == 160_000


def test_levels_follow_the_8bit_mapping():
    p = MapperParams()
    # probability = level / 256: p_min=0.07 -> 18 (0.0703), p_max=0.99 -> 253 (0.988)
    assert p.level_min == 18 and p.level_max == 253
    q = MapperParams(p_min=0.12, p_max=0.97)  # 0.12 -> 31 (0.121), 0.97 -> 248 (0.969)
    assert q.level_min == 31 and q.level_max == 248
    # p_occ = 0.65 -> occupied iff level > 166 (0.6484); 0.75 -> iff level > 192
    assert p.occ_threshold_level == 166
    assert MapperParams(p_occ=0.75).occ_threshold_level == 192


def test_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        MapperParams().p_occ = 0.8  # type: ignore[misc]


@pytest.mark.parametrize(
    ("field", "value", "allowed"),
    [
        ("p_occ", 0.5, "(0.5, 1)"),
        ("p_occ", 1.0, "(0.5, 1)"),
        ("p_sense", 0.4, "(0.5, 1)"),
        ("p_min", 0.5, "(0, 0.5)"),
        ("p_min", 0.0, "(0, 0.5)"),
        ("p_max", 0.5, "(0.5, 1)"),
        ("p_max", 1.0, "(0.5, 1)"),
        ("nu", 1.1, "[0, 1]"),
        ("nu", -0.1, "[0, 1]"),
        ("eps_m", -0.001, ">= 0"),
        ("delta_m", -0.01, ">= 0"),
        ("delta_m", float("nan"), ">= 0"),
        ("nx", 0, "positive int"),
        ("nz", 2.5, "positive int"),
        ("cell_m", 0.0, "> 0"),
        ("layer_m", -0.04, "> 0"),
        ("z_min_m", float("inf"), "finite"),
        ("max_range_m", 0.0, "> 0"),
        ("max_range_m", -1.0, "> 0"),
        ("max_range_m", float("nan"), "> 0"),
        ("max_range_m", "3", "> 0"),
        ("clear_outside", 1, "a bool"),
        ("cell_m", "0.04", "a float > 0 [m] in [0.001, 1.0]"),
        ("cell_m", 1e-9, "in [0.001, 1.0]"),
        ("layer_m", 1e9, "in [0.001, 1.0]"),
        ("p_occ", True, "in (0.5, 1)"),
        ("nx", 20000 * 20000, "at most 4194304 columns"),
        ("z_min_m", 1e300, "finite"),
        ("floor_memory", -1.0, "a finite float >= 0"),
        ("floor_memory", float("nan"), "a finite float >= 0"),
        ("floor_range_power", -1.0, "a finite float >= 0"),
        ("floor_range_power", float("inf"), "a finite float >= 0"),
    ],
)
def test_invalid_values_name_field_and_range(field, value, allowed):
    with pytest.raises(ValueError, match=field) as info:
        MapperParams(**{field: value})
    assert allowed in str(info.value)
    assert isinstance(info.value, InvalidParameterError)


def test_p_occ_must_stay_below_p_max_after_quantisation():
    with pytest.raises(ValueError, match="p_occ"):
        MapperParams(p_occ=0.975, p_max=0.97)


def test_with_overrides():
    p = MapperParams().with_overrides(p_occ=0.8, nx=50.0)
    assert p.p_occ == 0.8 and p.nx == 50 and isinstance(p.nx, int)
    with pytest.raises(ValueError, match="unknown MapperParams field"):
        MapperParams().with_overrides(p_occupied=0.8)


def test_max_range_and_clear_outside():
    p = MapperParams()
    assert p.clear_outside is True and p.max_range_m == float("inf")
    assert MapperParams(max_range_m=float("inf")).max_range_m == float("inf")
    q = p.with_overrides(clear_outside=0.0, max_range_m=2.5)
    assert q.clear_outside is False and q.max_range_m == 2.5
    assert q.with_overrides(clear_outside=1).clear_outside is True
