"""z-shift matching (Sec. IV): least squares with gating, acceptance and the withdraw rule."""

import numpy as np
import pytest

import mapper.mapper
from fogsim.config import load_scenario
from fogsim.run.runner import run_scenario
from mapper import MapperParams, ZDecision, ZMatch, apply_z_shift, frame_decision
from mapper.errors import InvalidInputError
from mapper.grid import GridGeometry
from mapper.zmatch import match_z, shift_from_residuals

P = MapperParams()
G = GridGeometry.from_params(P)


def level_from_numpy(residual, start, eps):
    """The plain numpy flat-window mean shift from ``start``: (centre, count)."""
    centre, count = start, 0
    for _ in range(64):
        inside = residual[np.abs(residual - centre) <= eps]
        if inside.size == 0:
            return centre, 0
        moved = float(sum(inside.tolist())) / inside.size  # in order, as the kernel's loop
        if inside.size == count and moved == centre:
            break
        centre, count = moved, inside.size
    return centre, count


def shift_numpy(residual, params):
    """The plain numpy gated shift (as before numba) the compiled one must equal bit for bit."""
    if residual.size == 0:
        return ZMatch(0.0, 0, float("nan"), False)
    kept = residual[np.abs(residual - np.median(residual)) <= params.eps_m]
    if kept.size == 0:
        return ZMatch(0.0, 0, float("nan"), False)
    shift = float(np.mean(kept))
    if params.zmatch_nearest_level and abs(shift) > 2.0 * params.eps_m:
        level, count = level_from_numpy(residual, 0.0, params.eps_m)
        enough = count >= params.zmatch_min_pairs
        share = count >= params.zmatch_nearest_min_share * kept.size
        if enough and share and abs(level) <= params.eps_m:
            kept = residual[np.abs(residual - level) <= params.eps_m]
            shift = float(np.mean(kept))
    rms = float(np.sqrt(np.mean((kept - shift) ** 2)))
    accepted = kept.size >= params.zmatch_min_pairs and abs(shift) <= params.zmatch_max_shift_m
    return ZMatch(shift, int(kept.size), rms, bool(accepted))


def match_z_numpy(points_world, floor_heights, floor_map, geometry, params):
    """The plain numpy gathering of pairs and shift the compiled `match_z` must equal."""
    h = np.asarray(floor_heights, dtype=np.float64)
    idx, valid = geometry.cell_of(np.asarray(points_world, dtype=np.float64)[:, :2])
    valid &= np.isfinite(h)
    if not np.any(valid):
        return ZMatch(0.0, 0, float("nan"), False)
    stored = floor_map[idx[valid, 0], idx[valid, 1]]
    residual = stored - h[valid]
    return shift_numpy(residual[np.isfinite(residual)], params)


def same_bits(a: ZMatch, b: ZMatch) -> bool:
    return (
        np.float64(a.shift_m).tobytes() == np.float64(b.shift_m).tobytes()
        and np.float64(a.rms_m).tobytes() == np.float64(b.rms_m).tobytes()
        and (a.pairs, a.accepted) == (b.pairs, b.accepted)
    )


def floor_map():
    f = np.full((P.nx, P.ny), np.nan)
    f[60:80, 40:60] = 0.0
    f[80:90, 40:60] = 0.061  # a step
    return f


def points_on(rng, n, x, y, h):
    pts = np.column_stack([rng.uniform(*x, n), rng.uniform(*y, n), np.full(n, h)])
    return pts, np.full(n, h)


def test_shift_is_least_squares_over_gated_pairs():
    rng = np.random.default_rng(1)
    # ground points measured 13 mm low, step points 13 mm low, outliers 0.2 m high
    g_pts, g_h = points_on(rng, 200, (0.41, 1.19), (-0.39, 0.39), -0.013)
    s_pts, s_h = points_on(rng, 50, (1.21, 1.59), (-0.39, 0.39), 0.061 - 0.013)
    o_pts, o_h = points_on(rng, 100, (0.41, 1.19), (-0.39, 0.39), 0.2)
    noise = rng.normal(0, 0.002, 250)
    pts = np.vstack([g_pts, s_pts, o_pts])
    h = np.concatenate([g_h, s_h, o_h])
    h[:250] += noise
    z = match_z(pts, h, floor_map(), G, P)
    assert z.pairs == 250  # outliers gated out
    assert z.shift_m == pytest.approx(0.013 - noise.mean(), abs=1e-12)
    assert z.rms_m == pytest.approx(noise.std(), abs=1e-12)
    assert z.accepted


@pytest.mark.parametrize("size", [1, 2, 7, 8, 9, 127, 128, 129, 136, 1000, 4099, 20001])
def test_compiled_shift_equals_numpy_bit_for_bit(size):
    rng = np.random.default_rng(size)
    residual = rng.normal(0.003, 0.004, size)
    assert same_bits(shift_from_residuals(residual, P), shift_numpy(residual, P))


def test_not_floor_and_unmapped_points_do_not_match():
    rng = np.random.default_rng(2)
    pts, h = points_on(rng, 100, (-1.0, -0.5), (0.0, 0.5), 0.0)  # no floor there
    z = match_z(pts, h, floor_map(), G, P)
    assert z == ZMatch(0.0, 0, z.rms_m, False) and np.isnan(z.rms_m)
    pts, h = points_on(rng, 100, (0.41, 1.19), (-0.39, 0.39), 0.0)
    z = match_z(pts, np.full(100, np.nan), floor_map(), G, P)
    assert z.pairs == 0 and not z.accepted


def test_acceptance_needs_pairs_and_a_plausible_shift():
    rng = np.random.default_rng(3)
    few = points_on(rng, P.zmatch_min_pairs - 1, (0.41, 1.19), (-0.39, 0.39), 0.01)
    z = match_z(*few, floor_map(), G, P)
    assert z.pairs == P.zmatch_min_pairs - 1 and not z.accepted
    far = points_on(rng, 100, (0.41, 1.19), (-0.39, 0.39), -0.1)
    z = match_z(*far, floor_map(), G, P)
    assert z.shift_m == pytest.approx(0.1) and not z.accepted


def test_frame_decision_rule():
    ok = ZMatch(0.01, 100, 0.002, True)
    bad = ZMatch(0.0, 3, 0.01, False)
    assert frame_decision(ok, ground_plane_found=False) == ZDecision.APPLY_SHIFT
    assert frame_decision(ok, ground_plane_found=True) == ZDecision.APPLY_SHIFT
    assert frame_decision(bad, ground_plane_found=True) == ZDecision.KEEP_UNSHIFTED
    assert frame_decision(bad, ground_plane_found=False) == ZDecision.WITHDRAW


def test_apply_z_shift():
    pts = np.array([[1.0, 2.0, 3.0]])
    p2, h2 = apply_z_shift(pts, [np.nan], 0.5)
    assert p2.tolist() == [[1.0, 2.0, 3.5]] and np.isnan(h2[0])
    assert pts[0, 2] == 3.0  # input untouched


def test_compiled_match_equals_numpy_on_edge_cases():
    rng = np.random.default_rng(4)
    pts, h = points_on(rng, 500, (-0.5, 6.0), (-3.0, 3.0), 0.01)
    pts[::7, 0] = np.nan
    pts[::11, 1] = np.inf
    h[::5] = np.nan
    fmap = floor_map()
    fmap[70, 45] = np.inf
    for case in ((pts, h), (pts[:, :2], h), (pts[:0], h[:0]), (pts[:3], h[:3])):
        assert same_bits(match_z(*case, fmap, G, P), match_z_numpy(*case, fmap, G, P))
    with pytest.raises(InvalidInputError, match="floor_heights must have shape"):
        match_z(pts, h[:-1], fmap, G, P)


def test_compiled_match_equals_numpy_on_the_stage_frames(monkeypatch):
    compiled = mapper.mapper.match_z
    matches = []

    def both(points, heights, floor, geometry, params):
        match = compiled(points, heights, floor, geometry, params)
        assert same_bits(match, match_z_numpy(points, heights, floor, geometry, params))
        matches.append(match)
        return match

    monkeypatch.setattr(mapper.mapper, "match_z", both)
    scenario = load_scenario("stage")
    run_scenario(scenario, None)
    assert len(matches) > 50 and sum(m.accepted for m in matches) > 25


def test_two_surfaces_far_apart_around_an_even_median_give_no_shift():
    # Residuals 0 and 0.1 m: the median (0.05 m) is more than eps (0.01 m) from both, so no pair
    # survives the gate; the match is empty and refused, never a NaN shift.
    params = MapperParams()
    match = shift_from_residuals(np.array([0.0, 0.0, 0.1, 0.1]), params)
    assert match == ZMatch(0.0, 0, match.rms_m, False)
    assert np.isnan(match.rms_m)


def two_levels(n_far, far_m, n_zero, seed=5):
    """Residuals of ``n_far`` pairs at ``far_m`` and ``n_zero`` at 0, each ±2 mm (uniform)."""
    rng = np.random.default_rng(seed)
    return np.concatenate(
        [far_m + rng.uniform(-0.002, 0.002, n_far), rng.uniform(-0.002, 0.002, n_zero)]
    )


def test_the_level_nearest_zero_wins_over_the_median_when_large_enough():
    # A frame sees mostly a surface the map holds 40 mm too low (residual −40 mm, 300 pairs) and
    # 100 pairs of ground the map holds right: the shift is the ground's, not the surface's.
    residual = two_levels(300, -0.040, 100)
    match = shift_from_residuals(residual, P)
    zero = residual[300:]
    assert match.pairs == 100 and match.accepted
    assert match.shift_m == pytest.approx(zero.mean(), abs=1e-15)
    assert match.rms_m == pytest.approx(zero.std(), abs=1e-15)
    # The paper's rule (the median's level) without it.
    paper = shift_from_residuals(residual, MapperParams(zmatch_nearest_level=False))
    assert paper.pairs == 300 and paper.shift_m == pytest.approx(residual[:300].mean(), abs=1e-15)


def test_a_level_near_zero_with_too_few_pairs_does_not_win():
    residual = two_levels(300, -0.040, P.zmatch_min_pairs - 1)
    match = shift_from_residuals(residual, P)
    assert match.pairs == 300
    assert match.shift_m == pytest.approx(residual[:300].mean(), abs=1e-15)


def test_a_median_level_within_eps_of_zero_is_kept_bit_for_bit():
    # Median at 6 mm: the rule is not asked; 9 mm wide spread reaches 0 but it is the same level.
    rng = np.random.default_rng(6)
    residual = np.concatenate([rng.normal(0.006, 0.003, 500), two_levels(200, -0.045, 0)])
    off = MapperParams(zmatch_nearest_level=False)
    assert same_bits(shift_from_residuals(residual, P), shift_from_residuals(residual, off))


def test_a_single_level_beyond_two_eps_is_reached_from_zero_and_kept():
    # One level at 24 mm (±6 mm): the window from 0 holds its lower tail, moves up to it and
    # stops on the same level, beyond eps of 0: the shift is the median's, bit for bit.
    rng = np.random.default_rng(7)
    residual = rng.normal(0.024, 0.006, 800)
    off = MapperParams(zmatch_nearest_level=False)
    match = shift_from_residuals(residual, P)
    assert abs(match.shift_m) > 2 * P.eps_m
    assert same_bits(match, shift_from_residuals(residual, off))


def test_two_levels_straddling_zero_within_two_eps_keep_the_median():
    # Stereo frames whose residuals spread over −15 mm and +9 mm (a tilt's far and near parts):
    # the median's level (−15 mm) is within 2·eps of 0, so the rule is not asked.
    residual = two_levels(500, -0.015, 300)
    residual[500:] += 0.009
    off = MapperParams(zmatch_nearest_level=False)
    assert same_bits(shift_from_residuals(residual, P), shift_from_residuals(residual, off))


def test_a_level_near_zero_with_too_small_a_share_does_not_win():
    # A frame off by one 25 mm step (stereo zig-zag: 3700 pairs at −27 mm on surfaces the map
    # holds right) with a few far pairs near 0 (60): the median's level is kept.
    params = MapperParams(zmatch_nearest_min_share=0.25)
    residual = two_levels(3700, -0.027, 60)
    match = shift_from_residuals(residual, params)
    assert match.pairs == 3700
    assert match.shift_m == pytest.approx(residual[:3700].mean(), abs=1e-15)
    # Without the share (0), the 60 pairs win as before.
    assert shift_from_residuals(residual, MapperParams(zmatch_nearest_min_share=0.0)).pairs == 60


@pytest.mark.parametrize(("n_zero", "wins"), [(100, True), (99, False)])
def test_the_share_is_counted_against_the_median_level(n_zero, wins):
    # 400 pairs at −40 mm: a level near 0 needs a quarter of them, 100 pairs.
    params = MapperParams(zmatch_nearest_min_share=0.25)
    residual = two_levels(400, -0.040, n_zero)
    match = shift_from_residuals(residual, params)
    assert match.pairs == (n_zero if wins else 400)
    assert same_bits(match, shift_numpy(residual, params))


@pytest.mark.parametrize("seed", range(8))
def test_compiled_nearest_level_equals_numpy(seed):
    rng = np.random.default_rng(seed)
    residual = np.concatenate(
        [rng.normal(-0.03, 0.004, 400), rng.normal(0.0, 0.004, rng.integers(0, 120))]
    )
    assert same_bits(shift_from_residuals(residual, P), shift_numpy(residual, P))
    shared = MapperParams(zmatch_nearest_min_share=0.25)
    assert same_bits(shift_from_residuals(residual, shared), shift_numpy(residual, shared))
