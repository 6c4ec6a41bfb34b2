"""`bench/heading_witness.py`: the plane witness's calls recorded with their fits."""

import math
import sys
from pathlib import Path

import pytest
from test_heading import _walk_at_l_shaped_wall

from mapper.heading import HeadingEstimator, HeadingParams

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
heading_witness = pytest.importorskip("heading_witness")


def _walked(side_wall: bool, **params):
    estimator = HeadingEstimator(
        HeadingParams(estimate_every=1, edge_score=False, min_contrast=0.9, **params)
    )
    with heading_witness.recorded_witnesses() as calls:
        _walk_at_l_shaped_wall(estimator, 1.3, side_wall=side_wall)
    return estimator, calls


def test_a_loose_witness_is_recorded_with_its_standard_error_and_refused():
    # The wall across the path alone (`test_the_plane_witness_refuses_fits_looser_than_their_
    # agreement`): the first call's two fits both end near 0 with a standard error of about
    # 0.17°, above the default bound of 0.1°: refused. Without the bound the same call is the
    # accepted estimate, near 0 where -1.3° is needed.
    estimator, calls = _walked(side_wall=False)
    assert estimator.estimates == 0 and calls
    first = calls[0]
    assert len(first.fits) == 2 and first.accepted_deg is None
    for fit in first.fits:
        assert fit.information > 0.0
        assert fit.sigma_deg == pytest.approx(
            math.degrees(fit.rms_mm / 1000.0 / math.sqrt(fit.information))
        )
        assert 0.1 < fit.sigma_deg < 0.25
        assert fit.end_deg == pytest.approx(0.0, abs=0.1)
    _, loose = _walked(side_wall=False, plane_witness_sigma_deg=0.0)
    assert loose[0].accepted_deg == pytest.approx(loose[0].fits[0].end_deg)
    assert "-> accepted" in heading_witness.line("wall", -1.3, loose[0])
    assert "-> none" in heading_witness.line("wall", -1.3, first)


def test_a_tight_witness_is_accepted_and_the_patches_are_undone():
    # With the side wall the fits' standard error is about 0.02°: the first call is accepted
    # at the fit, within 0.06° of the 1.3° error. After the block the estimator's own methods
    # are back.
    witness, plane_fit = HeadingEstimator._plane_witness, heading_witness.heading_module._plane_fit
    estimator, calls = _walked(side_wall=True)
    accepted = [call for call in calls if call.accepted_deg is not None]
    assert estimator.estimates == 1 and len(accepted) == 1
    assert accepted[0].accepted_deg == pytest.approx(-1.3, abs=0.06)
    assert all(fit.sigma_deg < 0.05 for fit in accepted[0].fits)
    assert HeadingEstimator._plane_witness is witness
    assert heading_witness.heading_module._plane_fit is plane_fit
