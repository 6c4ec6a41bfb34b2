"""Plane segmentation of depth images into floor (with height) and obstacle points.

Implements the paper's segmentation step (Gutmann et al., Sec. III-A and IV): range points are
grouped into planes by scan-line grouping (Jiang & Bunke; details in `mapper.scanline`):

- the depth noise is estimated per pixel from the data (second differences of inverse depth,
  capped by the image's typical noise at that depth), and every tolerance scales with it;
  with a stereo noise model (`SegmentationParams.disparity_noise_px`, ``stereo_baseline_m``)
  the typical noise is the model's ``d²·σ_d/(f·b)`` and the floor of the local estimate, and
  tests of means allow for correlated noise (``noise_correlation_factor``);
- each image row is split into straight pieces (no outlier, no excess RMS, no depth step);
- planes are seeded from the best-fitting triples of overlapping pieces in adjacent rows and
  grown breadth-first, then pieces move to a neighbouring plane that fits them clearly better
  and leftover pixels next to a plane join it if they fit.

Planes are fitted as inverse depth affine in the image coordinates, so errors are measured
along the viewing ray, where a depth camera has them. Then

1. the data are rotated about the camera centre so that the near-horizontal planes become
   exactly horizontal (mean normal of the planes agreeing with the best-supported one, each
   weighted by the information of its normal, 1/σ² from the fit's covariance: a far plane's
   large footprint does not outvote a near plane's well-determined normal; absorbs camera
   rotation errors of the joint encoders);
2. floors are grown in that frame with the one-parameter model ``z = h``
   (`scanline.levels.split_level`, `scanline.levels.grow_floors`): row pieces split where
   their heights step, level pieces (heights scattering by their noise along z, the typical
   depth noise times the ray's z component) joined to touching level pieces of the same mean
   height.
   A free plane can tilt and creep up a staircase tread by tread when 1-2 % depth noise hides
   each small step; a level region cannot. A region is a floor when it has at least
   `min_plane_pixels` pixels in 3 or more segments, a footprint at least
   `min_plane_extent_m` wide in every direction (room for a foot), a slope within
   `floor_max_normal_angle_deg`, and is smooth: its RMS height residual against the typical
   noise at that range (`floor_max_rms_ratio`) and the scatter of its segments' mean heights
   (`floor_max_segment_chi2`) rule out rough tops that noise makes look level;
3. everything is shifted in z so that the floor nearest the expected ground plane (among
   those with at least a quarter of the largest candidate's area) lies on it; if none is
   within the search window, nothing is shifted and `PoseCorrection.ground_plane_found` is
   False;
4. points in no level region whose depth lies within noise of the ground become ground points
   (far noisy ground is floor, never an obstacle below it), and every floor point is moved
   along its ray to its floor's height (depth noise lies along the ray: the point gets its
   true x, y, so a higher tread's points never land on the lower one); a floor point that
   lies farther from its floor than noise explains loses its label. Before that (with
   `floor_side_strip_px`, the stereo head's) a band of a floor region's sides that lies at the
   level of another floor it touches moves to that floor (`mapper.floor_sides`): rows that
   did not split at a tread's side edge carry the tread's region over the edge; and (with
   `floor_occluding_border_px`, off by default) a floor's pixels on the near side of an
   occluding edge leave it (`mapper.floor_borders`): a matcher spreads them past the edge.

Every floor point is labelled with its region's height (weighted mean corrected z of the
grown segments' points); all other points are obstacle (``NaN``).

Frames: camera = OpenCV optical frame (x right, y down, z forward); robot frame R = z up,
origin on the ground below the robot.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from mapper import floor_borders, floor_sides, scanline, tilt_kernels
from mapper.errors import InvalidInputError, InvalidParameterError
from mapper.intrinsics import PinholeIntrinsics
from mapper.limits import (
    MAX_COORDINATE_M,
    MAX_SEGMENTATION_PASSES,
    MAX_WINDOW_PX,
    RIGID_TOLERANCE,
)
from mapper.pose_correction import (
    PoseCorrection,
    estimate_tilt,
    ground_shift,
    stepped_planes,
)
from mapper.validation import check_field, real_array, rigid_transform

__all__ = [
    "PoseCorrection",
    "SegmentationParams",
    "SegmentationResult",
    "floor_regions",
    "segment_depth",
]


_POSITIVE_FIELDS = (
    "max_depth_m",
    "min_noise_m",
    "split_sigma_factor",
    "split_rms_sigma_factor",
    "edge_sigma_factor",
    "break_sigma_factor",
    "grow_sigma_factor",
    "rms_sigma_factor",
    "ground_search_window_m",
    "tilt_pitch_sigma_factor",
)
"""`SegmentationParams` fields that must be finite and > 0."""
_NON_NEGATIVE_FIELDS = (
    "min_depth_m",
    "tolerance_floor_m",
    "fill_sigma_factor",
    "min_plane_extent_m",
    "noise_cap_factor",
    "floor_max_rms_ratio",
    "floor_max_noise_ratio",
    "floor_roughness_m",
    "floor_roughness_min_extent_m",
    "ground_relabel_sigma_factor",
    "floor_snap_sigma_factor",
    "floor_height_tolerance_m",
    "floor_max_segment_chi2",
    "disparity_noise_px",
    "plane_refit_sigma",
    "stereo_baseline_m",
    "tilt_max_step_t",
    "floor_occluding_border_min_width_m",
    "floor_step_split_t",
)
"""`SegmentationParams` fields that must be finite and >= 0."""
_INTEGER_RANGES: dict[str, tuple[int, int | None]] = {
    "noise_window_px": (1, MAX_WINDOW_PX),
    "edge_window_px": (2, MAX_WINDOW_PX),
    "break_reach_px": (0, MAX_WINDOW_PX),
    "fill_passes": (0, MAX_SEGMENTATION_PASSES),
    "break_passes": (0, MAX_SEGMENTATION_PASSES),
    "reassign_passes": (0, MAX_SEGMENTATION_PASSES),
    "min_segment_pixels": (2, None),
    "seed_min_pixels": (2, None),
    "min_plane_pixels": (3, None),
    "floor_edge_margin_px": (0, MAX_WINDOW_PX),
    "floor_height_margin_px": (0, MAX_WINDOW_PX),
    "plane_normal_margin_px": (0, MAX_WINDOW_PX),
    "floor_side_strip_px": (0, MAX_WINDOW_PX),
    "floor_occluding_border_px": (0, MAX_WINDOW_PX),
    "structure_border_px": (0, MAX_WINDOW_PX),
}
"""Integer `SegmentationParams` fields: (lowest, highest or None) allowed. The windows' widths
and the passes' counts are bounded (`mapper.limits`); the pixel counts only filter."""


@dataclass(frozen=True)
class SegmentationParams:
    """Parameters of `segment_depth` (lengths in metres, angles in degrees).

    Every field is checked on construction (type and range); a wrong one raises
    `InvalidParameterError` naming the field, the value and what is allowed.

    Attributes:
        min_depth_m: depths below this are no measurement [m].
        max_depth_m: depths above this are no measurement [m]; set it to the sensor's range
            limit when the sensor cuts there itself. The cut is on the measured depth, so near
            it only the pixels measured too near are left: the tilt's normals come from each
            plane's pixels predicted well inside it (`scanline.plane_pixels.plane_refits`). 10
            (default): beyond any indoor scene; fogsim's depth and stereo modes cut at the camera's
            ``range_m`` (4 m): with 10 here the stage's tilt read −0.38 mrad forward (depth
            mode, seed 1, every 4th frame; −0.15 with 4 here, the rest the treads' borders:
            `plane_normal_margin_px`), which put the treads near the camera 0.4 mm high
            against the far ground in the map.
        noise_window_px: half width of the box (3 rows high) estimating local noise [px].
            Windows and passes are bounded by `mapper.limits.MAX_WINDOW_PX` and
            `mapper.limits.MAX_SEGMENTATION_PASSES` (their cost grows with them).
        min_noise_m: lower bound of the per-pixel depth noise [m].
        noise_cap_factor: the local noise is capped at this multiple of the image's typical
            noise at the same depth (rough surfaces can't widen their own tolerances); 0: off.
        tolerance_floor_m: constant added to every distance tolerance [m] (for exact data).
        split_sigma_factor: a row pixel farther than this many sigma from its line splits it.
        split_rms_sigma_factor: a row piece whose RMS residual exceeds this many sigma is split.
        edge_window_px: pixels either side of a boundary for the depth-step test in rows.
        edge_sigma_factor: a depth step of more than this many standard errors splits a row.
        break_sigma_factor: the same, at columns where the row above or below breaks.
        break_passes: rounds of propagating row breaks up and down.
        break_reach_px: columns either side of a neighbouring row's break searched for a step.
        reassign_passes: rounds of moving segments to a neighbouring plane that fits better.
        grow_sigma_factor: segment end points must lie within this many sigma of the plane
            (sigma of the fitted line end, i.e. 2·sigma/sqrt(n)).
        rms_sigma_factor: a segment's RMS distance to the plane must be within this many sigma.
        fill_sigma_factor: leftover pixels join a neighbouring plane within this many sigma.
        fill_passes: how many pixels deep leftover pixels may join a plane.
        min_segment_pixels: shorter row pieces are no segments.
        seed_min_pixels: minimum length of each of the three segments of a plane seed.
        min_plane_pixels: planes with fewer pixels are dissolved (their pixels: no plane).
        min_plane_extent_m: a floor plane's footprint must be at least this wide in every
            direction (sqrt(12)·std of its points along the minor in-plane axis) [m].
        floor_max_rms_ratio: a floor region's RMS height residual is at most this multiple of
            the image's typical noise along z at its pixels (the range profile, not the local
            estimate a rough surface widens; squared residuals clipped at 9, so a row of riser
            pixels joined to a tread does not count as roughness; pixels of the region's ring,
            `floor_height_margin_px`, farther from its level than `floor_snap_sigma_factor`
            sigma are left out: the neighbouring surface's, joined one-sidedly, such as a box
            top's side face below its rim — moving_box, depth, seed 2: the top 1.3 m away was a
            floor in half of the frames and the map dropped it, Table I −60 mm; with them left
            out 0.29 mm mean, 0.61 mm worst over seeds 1-8). 1.05: a flat surface's
            ratio is about 0.95; on stage recordings (seeds 1, 2) 99.5 % of the floor pixels
            in regions passing the other tests lie in regions below 1.05, while 93 % of the
            regions on the rough box tops lie above it (a rough top labelled floor in one
            frame stays floor in the map: eq. 9 keeps the highest floor); 0: off.
        floor_max_noise_ratio: a floor region's pixels' mean local noise estimate (the second
            differences in a window reaching `noise_window_px` columns and a row beyond each
            pixel, so over pixels the level growing left out too; capped by
            `noise_cap_factor`) is at most this multiple of the typical noise at their depth
            (the sensor model's, else the image's): the bumps around a rough top's level
            patch read as noise where the region's own pixels, selected as level, do not.
            0 (default): off. Measured (session 35): fogsim's depth mode, every frame of
            stage seed 3, 22 of the 25 rough-top regions that pass every other test have a
            ratio above 1.3 (1.02-1.5; flat floors 1.0, 95 % below 1.14), and 0.07 % of the
            other floor pixels; on the depth replays, seeds 1-8, 1.3 (1.4): floor recall
            talos_course 96.80 → 94.44 % (96.62: its sensor model under-reads the ground's
            noise at 2-3 m, 3 % of the floor pixels there), table 98.10 → 95.93 % (97.66),
            unsafe cells stage_zigzag 11.25 → 11.88 (11.13), stairs 2.50 → 2.38 (2.25), and
            the stage 0 → 1.25 (10) both: fewer floor points move the heading estimator's
            structure points, seed 7's map heading 0.35 → 0.40° spills the platform a cell
            over its side edge. Stereo: no effect (the model floors the local estimate; a
            matcher's smoothing leaves rough tops at 0.45-0.9 of it, flat floors 0.36-1.1).
            `MapperParams.min_floor_frames` takes the patches that reach the map instead.
        floor_roughness_m: the unevenness a floor may have besides the sensor noise [m, RMS]:
            the RMS ratio of a region at least `floor_roughness_min_extent_m` wide is taken
            against sqrt(σ_z² + ``tolerance_floor_m``² + this²) instead of sqrt(σ_z² +
            ``tolerance_floor_m``²), so a surface uneven by this much passes where the sensor
            resolves millimetres and the test is nearly unchanged where it does not (at σ_z
            10 mm by 4 %). A foot stands on a tread level within ±5 mm (the growing's
            `floor_height_tolerance_m` lets segment means differ by as much); unevenness spread
            evenly over ±5 mm has an RMS of 5/√3 = 2.9 mm. 3 mm: the measured treads
            of ``eth_stairs`` (an ANYmal elevation map, 8-bit heights: 4.9 mm steps) read
            1.16–1.33 at σ_z of 2–3 mm (about 2 mm RMS of unevenness) and its landing
            1.02–1.13, so 63 % of its frames had no floor but the ground and were withdrawn
            (seeds 1-8, depth: 144 of 227 frames, 30 % of the seen floor found); with 3 mm none
            is withdrawn and 87 % of the floor is found (2 mm left 1–2 frames withdrawn on 2 of 4
            seeds). But the floor it finds there shows what the withdrawn frames hid: unsafe
            cells 5.9 (13) → 146 (195) per run (91 from treads above the grid's 0.58 m top,
            34 at edges moved by the 2.4° residual heading, 22 heights more than 20 mm off),
            obstacle recall 98 → 24 %, and ``room`` 1.5 (5) → 2.0 (8), so it is off by default;
            3 mm is the value to try on measured, uneven terrain. Synthetic tops seen at 45°
            from 0.9 m through the depth mode's noise (`tests/test_segmentation.py`): ±5 mm
            bumps are floor on 8 of 8 seeds (6 of 8 without), ±2 and ±4 cm bumps on none, as
            without. 5 mm (without the extent test)
            let the rocks of ``room``, ``stage`` and ``talos_course`` into the map: unsafe cells
            1.5 → 39.4, 0 → 8.9, 0.25 → 8.0 per run (depth, seeds 1-8). 0 (default): off.
        floor_roughness_min_extent_m: narrower regions (minor extent, as
            `min_plane_extent_m`) keep the plain RMS ratio [m]. A rough top's level regions
            are the patches whose noisy heights happen to lie near one level (growing selects
            pixels by their height), so their RMS understates the top's roughness and many sit
            just above `floor_max_rms_ratio`; the allowance turned them into floors (3 mm for
            every region: unsafe cells on ``room`` 1.5 → 8.0, ``stage`` 0 → 2.25,
            ``talos_course`` 0.25 → 2.1 per run, depth, seeds 1-8). Such patches are narrower
            than the rough objects (at most 0.35 m): the ones 3 mm made floors were 0.08–0.23 m
            wide (``room``, ``talos_course``, ``stage_zigzag`` seed 1 and ``stage`` seed 3,
            depth, every 2nd frame; 0.16–0.18 m on ``stage_zigzag`` stereo), while the
            ``eth_stairs`` treads are 0.28–0.55 m. 0.25 (default; a stair's going is at least
            about that): ``stage_zigzag`` unsafe cells 11.25 → 11.5 per run (a gate of 200
            pixels instead: 14.4, its rough box tops are seen from nearby), ``room`` 1.5 → 2.0;
            ``eth_stairs`` loses its narrow views of the landing (87 % of its floor found
            instead of 94 % with the pixel gate; none withdrawn either way). 0: every region.
        ground_relabel_sigma_factor: a point in no level region whose depth is within this many
            sigma (the typical noise at its depth) of where its ray meets the ground plane is
            a ground point (labelled with the ground's height). 3: far, noisy ground that
            formed no plane then lies on the ground instead of becoming obstacle points below
            it, while an obstacle's points are farther from the ground than 3 sigma but at
            its very foot. 0: off; nothing is relabelled without a ground plane.
        floor_height_tolerance_m: constant added to the height tolerance of growing and
            filling floor regions [m]. 5 mm: the residual tilt after the correction (a few
            tenths of a degree) bends a large ground region by that much, while it stays below
            half the 31 mm smallest step of the paper's staircase, so a region never climbs one.
        floor_max_segment_chi2: a floor's row segments' mean heights scatter about a plane
            fitted to them with a reduced chi² (the growing tolerance added to every standard
            error, `scanline.floors.floor_segment_fit`) of at most this times 1 + 3·sqrt(2/dof), the
            reduced chi²'s mean plus three standard deviations for dof = segments − 3. 1.0:
            a flat floor's segments scatter by their errors (chi² about 0.5 with the
            tolerance on stage recordings), while on a rough top they scatter by the bumps,
            which a segment's mean does not average away; 0: off.
        floor_snap_sigma_factor: every floor point whose ray meets its floor height within
            this many sigma (typical noise at its depth) of its measured depth is moved there
            along its ray (depth noise lies along the ray: the point then has the right x, y
            and z = its height, so a tread's points never spill onto its neighbours); a floor
            point whose ray does not is no floor point. 3 (as above); 0: off, points stay where
            measured.
        floor_max_normal_angle_deg: a floor plane's normal is within this angle of vertical
            after the tilt correction [deg].
        max_tilt_correction_deg: planes whose normal is within this angle of vertical (before
            correction) steer the tilt correction, which is at most this large [deg]. 20: neck
            encoder errors reach 13.8° on the stage (issue 11); the largest-area group of
            agreeing planes keeps a ramp from steering it.
        tilt_consensus_deg: of those, only planes whose normal is within this angle of the
            reference (the largest-area consensus) are averaged [deg].
        expected_ground_z_m: z of the ground plane in the robot frame [m].
        ground_search_window_m: the ground plane is searched within this distance of
            `expected_ground_z_m` [m] (after the tilt correction).
        correct_tilt: apply the rotation correction.
        correct_ground_shift: apply the z shift to the ground plane.
        disparity_noise_px: std of a stereo camera's disparity noise [px of this image];
            with ``stereo_baseline_m`` it sets the sensor model: inverse depth has the
            constant std ``σ_d/(f·b)`` (f = `PinholeIntrinsics.fx`), so the depth noise is
            ``d²·σ_d/(f·b)``. Then the typical noise at each depth is the model's and the
            local estimate never falls below it: a matcher's errors are correlated over its
            window and second differences of neighbours read them at about 0.6× their size
            (fogsim's stereo head on the stage). 0 (default): no model, the noise is the
            image's own (any depth sensor). For fogsim's stereo head 0.109 px: the std of the
            Gaussian with the matcher's 99th percentile (`bench/stereo_stats.py`, stage seeds
            1-3: robust std 0.074 px, 99 % tail 0.109 px; k-sigma tests need the tail).
        stereo_baseline_m: the stereo baseline b [m] of that model (0: no model).
        noise_correlation_factor: how much correlated noise inflates the variance of a mean
            of n neighbouring pixels of a row over the white-noise σ²/n (τ ≥ 1). Every test
            of a mean against a mean (the step statistics of row splitting, level segments'
            mean heights when growing floors, the floors' segment-mean χ², the planes' normal
            uncertainty) widens its standard error by sqrt(τ). 1 (default): white noise. For
            fogsim's stereo head 3: `bench/stereo_stats.py` measures 1.9, 2.3, 2.7 for runs
            of 4, 8, 16 pixels (stage seed 1) and row segments span 10–40 pixels.
        floor_edge_margin_px: a floor region's RMS ratio and slope come from its pixels
            farther than this from its border (up, down, left and right; all of them when it
            has none so far inside): a stereo matcher's window blends the border pixels with
            the neighbouring surface, which reads as roughness (and pulls a narrow region's
            height: `floor_height_margin_px`). 0 (default): every pixel counts (a depth sensor
            without a matching window; left out, the border of a rough box top no longer counts
            against it: stage depth seed 1, 7 % more box pixels labelled floor). For fogsim's
            stereo head 1 (its window is 5 render px, 2.5 output pixels): on the stage (seed 1)
            the sill top's far row reads 10-25 mm low while its inner rows are within 4 mm, and
            the steps' floor pixels at 1-1.5 m (seed 4, true pose) are labelled twice as often
            and within 3 mm in the median instead of 11 mm low.
        floor_height_margin_px: a floor region's height comes from its pixels at least this far
            inside its border (up, down, left and right, `scanline.regions.region_depth`); a region
            with none (a narrow tread seen from afar) takes its deepest pixels, one with no pixel
            inside its border ring all of them (before session 35 every region without a pixel this
            deep took all its pixels, the border's too). Growing selects one-sidedly at a border: at
            a box top's rim the pixels just over the edge, on the side face, lie below the top, and
            those within the noise tolerance join the top's region — only from below, so they pull
            its height down in proportion to the noise (not at all on exact data). 1 (default): the
            rim's ring of pixels is left out (moving_box, depth mode, seeds 1-8, frames 180-218: the
            flat box top 0.75 ± 0.07 mm below the ground's +60 mm with every pixel, 0.10 ± 0.05 mm
            without the ring; a synthetic box seen from the side: 0.79 mm low with 13 side-face
            pixels in its region of 234, 0.04). A stereo matcher's window rounds a tread's convex
            edges towards the farther surface over more rows: fogsim's stereo head (window 2.5
            output pixels), a 38 mm sill and a 31 mm step seen from 0.93 m high (63 views, exact
            depth as reference): the first row from an edge reads 6.8 / 4.9 mm low, the second 1.9
            mm low on the step, the third and fourth within 1.2 mm. 2 there (stereo replays, seeds
            1-8, session 35, 1 → 2, mean (worst)): Table I rows stage sill 2.23 (3.46) → 1.27 (2.04)
            mm, every stage row better, room sill 1.02 (1.87) → 0.76 (1.19); but the zig-zag stage's
            sill 0.80 (1.37) → 1.03 (3.26, seed 8) and unsafe cells stage 5.0 (8) → 6.75 (12),
            zig-zag 31.9 (70) → 32.75 (87) (room 9.0 → 8.0, stage_down 6.5 → 5.6), so the stereo
            head keeps 1 (3: stage step_1 1.22 (1.44) mm, stage_down's rows within 2.49 mm, room
            11.25 unsafe cells). Only the border ring counts as a rim that a neighbouring surface
            may have lent (`_foreign_rim`), whatever the margin.
        plane_refit_sigma: the tilt correction takes each plane's normal from a refit on its
            pixels within this many sigma of the first least-squares fit (sigma: that fit's
            RMS residual, at least ``min_noise_m`` at the pixel's depth;
            `scanline.plane_pixels.plane_refits`), so a stereo matcher's edge-fattened pixels
            don't tilt it; everything else uses the first fit. 0 (default): no outlier test (a depth
            sensor without a matching window; the refit still leaves out the pixels near
            `max_depth_m`). For fogsim's stereo head 1 (`fogsim.sim.camera.noise_model`).
        plane_normal_margin_px: the tilt correction takes each plane's normal from its pixels
            farther than this from its border (as `floor_height_margin_px`; a plane without
            such pixels keeps its first fit). Growing takes the neighbouring surface's pixels
            within the noise tolerance at a plane's border, from one side: at a tread's back
            edge the riser above it, at its front edge the riser below, both leaning its
            normal back towards the camera, the narrower the plane the more. 1 (default): the
            ring of border pixels is left out (stage, depth mode, seeds 1-3, every 4th frame,
            the treads' normals 4-8 mrad off and the frames' tilt −0.09 to −0.17 mrad, at most
            −0.05 without the ring; with `max_depth_m` 4). 0: every pixel counts.
        floor_side_strip_px: the widest band of a floor region's sides tested for lying at
            another floor's level [px] (`mapper.floor_sides`). A row whose noise hides a step
            is not split there, so a tread's rows run on over its side edge and its region
            takes the surface beside it (stereo, stage seeds 1 and 4: ground pixels 2–6 cm
            past step_1's side edge, at the right depth, labelled with the step's height). The
            k-th pixels from the left (right) ends of a region's row runs, pooled over its rows,
            are its k-th strip; the band of outermost strips whose mean height lies farthest
            from the region's level, in standard errors (``noise_correlation_factor``) beyond
            ``floor_height_tolerance_m``, moves to a floor region it touches when its score
            exceeds ``grow_sigma_factor``, its mean fits that floor's level by the same test
            and its RMS about that level passes ``floor_max_rms_ratio``; the region's level is
            then taken without it. A band that fits no touching floor stays. 0 (default): off.
            fogsim's depth mode resolves the stage's steps in its rows: with 32 on the depth
            replays (10 scenarios, seeds 1–8, session 37) every one of the 423 report figures
            was the same as with 0, so the depth model leaves it off (no work a frame). For
            fogsim's stereo head 32 (`fogsim.sim.camera.noise_model.MATCHER_SIDE_STRIP_PX`):
            stereo replays, seeds 1–8, 0 → 32, unsafe cells mean (worst) stage 5.0 (8) → 2.25
            (5), stage_down 6.5 (27) → 4.4 (9), room 9.0 (16) → 8.6 (13), zig-zag 31.9 (70) →
            31.1 (66); the stage's Table I rows all closer (sill 2.23 (3.46) → 1.78 (3.05) mm,
            step_1 1.89 (2.19) → 1.26 (1.54), step_3 0.76 → 0.54): the ground the treads' side
            bands took had pulled their levels down. Costs: stage obstacle recall 99.4 (98.3)
            → 99.2 (97.2) % (the sill's back riser cells, which the spilled sill height had
            made obstacles, get the ground's floor), stage_down platform 0.36 (1.06) → 0.39
            (1.23) mm, room's sill 1.02 → 1.07 mm mean (worst 1.87 → 1.82), stage sill
            coverage 82.5 → 77.7 %. 8 and 16 gave the same within 0.5 cells a run (8: stage
            2.0 (5), zig-zag 31.5 (68); 16: 2.25 (5), 31.5 (68)). Time: 0.92 → 0.97 ms CPU a
            frame (median, stage stereo seed 1, every 4th frame, 3 repeats interleaved).
        floor_occluding_border_px: a floor region's pixels within this many pixels (along the row or
            column) of a pixel of another label that is farther by more than `OCCLUDING_JUMP_SIGMA`
            of the stereo model's inverse-depth noise are no floor points (`mapper.floor_borders`):
            a stereo matcher's window spreads the nearer surface's disparity over the farther one's
            first pixels at an occluding edge, which puts a raised surface's floor a cell past its
            side and far edges, over ground no ray can refute. Judged in the stereo model's noise
            (``stereo_baseline_m``, ``disparity_noise_px``): without that model (a depth camera) it
            does nothing (the scenario tables and overrides are checked before the head's model is
            merged in, so this cannot be refused there). 0 (default): off — also for fogsim's stereo
            head, because it did not carry over to the scenes it was not tried on. 1 on the stereo
            head (session 49, seeds 1–8, unsafe cells mean (worst)): the shipped suite 167.75 →
            125.1 in all (`stairs` 37.4 (79) → 15.6 (46), `talos_course` 33.4 (57) → 26.9 (36), the
            zig-zag 24.0 (53) → 19.5 (44), `untextured` 7.9 → 3.9, `moving_box` 11.9 → 10.1 with
            obstacle recall 22 → 45 %; worse: the stage 1.25 (3) → 1.62 (6), `room` 6.88 → 7.25,
            `table` 1.25 → 1.50), floor recall 0.2–1.9 points lower, the stage's sill coverage 86 →
            62 %, the zig-zag's sill 19 → 12 % with its one cell left on seed 8 16.3 mm off; the
            held-out scenes 451.4 → 434.6 only — `stairs_35_65_100` 31.25 (103) → 54.6 (151),
            `down_low_steps`' worst seed 198 → 229, `rock_field`'s sill coverage 71 → 12 % — against
            `down_slant_turn` 96.75 → 85.75 and `stairs_40_75_110` 75.0 → 61.1. Every label change
            taken as a border (not only an occluding one): shipped 167.75 → 319.6, `talos_course`
            seed 7 a whole-map failure (1553 cells), floor recall up to 5 points lower. On top of
            session 50's stereo head (`structure_border_px`, the heading's `flat_contrast`):
            shipped 151.0 → 127.4 (`talos_course` 39.5 (88) → 28.75 (49), `stairs` 13.5 → 16.25
            worse), held out 440.9 → 421.75 (`down_slant_turn` 96.1 (151) → 103.9 (241)), but
            the zig-zag's sill row on seed 8 left with one cell 33.9 mm off (its coverage 18 → 12
            %), `rock_field`'s sill coverage 75 → 18 %, the stage's 79 → 64 %: still off. Try it
            with ``--set segmentation.floor_occluding_border_px=1``.
        floor_occluding_border_rows_only: `floor_occluding_border_px` looks along the row only:
            a side edge's spill (the ground beside a tread seen left or right of it) goes, a far
            edge's (the ground behind a sill, seen above it in the image) stays — a sill's top
            at range is a few rows of pixels, and the far edge's border took them. Off by
            default: on the stereo head with ``floor_occluding_border_px=1`` (session 55, the
            suites seeds 1–8, unsafe cells mean (worst) in all, default → rows only → both
            directions): held-out 420.75 → 394.38 → 410.00 (`stairs_40_75_110` 67.2 (107) →
            58.0 (70); worse `stairs_35_65_100` 32.0 (103) → 36.2 (159)), issue 11's checks
            met 65 → 63 → 59 of 209, `rock_field`'s sill row on 21–27 cells a seed (23–27 by
            default, 0–17 both directions); shipped 150.88 → 140.25 (`talos_course` 39.5 (88)
            → 35.8 (70), `untextured` 7.9 → 5.2; worse `stairs` 13.5 (41) → 16.4 (48),
            `stage_down` 2.0 (5) → 2.4 (10)), checks 160 → 161 of 262, but the zig-zag's sill
            row on seed 8 0.32 mm (4 cells) → 16.32 mm (2 cells). (fogsim's depth mode has
            a stereo-equivalent noise model too, so set there both apply; not measured.)
            fogsim's stereo head sets it with `floor_occluding_border_min_width_m`
            (`fogsim.sim.camera.noise_model.MATCHER_FLOOR_BORDER` has the figures).
        floor_occluding_border_min_width_m: floors whose footprint's minor width
            (`FloorTable.extents_m`) is below this keep their occluding border [m]: a sill's
            top (0.06–0.10 m wide on the shipped scenes) seen at a slant has its far edge
            across the rows too, and its few rows at range are most of it. 0 (default): every
            floor; fogsim's stereo head 0.15 (treads are 0.2 m deep and more).
        floor_step_split_t: a level region that fits better as a plane with a step than as a
            plane — the step's t-statistic (correlated noise: ``noise_correlation_factor``)
            above this and its height at least `mapper.scanline.steps.MIN_STEP_M` — is split
            along the step (`mapper.scanline.steps`): a low tread and the ground beside its side
            edge, which the rows ran on over under stereo noise. 0 (default): off, for depth and
            stereo alike. 8 is where it was measured (session 56: over every region of the
            `flat_floor` and `room` stereo recordings the best split scores at most 6.4, joined
            ground and step_1 9–11), on fogsim's stereo suites over seeds 1–8, unsafe cells in
            all, off → on: shipped 142.62 → 125.25 (`talos_course` 35.9 (74) → 24.4 (42),
            `stairs` 16.4 (48) → 11.0 (41)) and held-out 394.88 → 463.62: `down_landing_turn`'s
            step_1 13.9 → 0.3 mm off on seed 3 and 13.9 → 1.6 on seed 7, `down_slant_turn`'s
            step_1 and platform 12–16 → 2–4 mm on seeds 6 and 8, but `down_slant_turn` seed 7
            141 → 873 unsafe cells (its last frames, seeing the steps from below at an angle,
            z-matched 10–30 mm lower: the steps and platform 20 mm low), `stairs_35_65_100`
            seeds 1–2 rows +2…+5 mm, Table I rows 0.5 mm or more better / worse: held out 47 /
            43, shipped 14 / 22 (`talos_course` −1…−2 mm on five seeds); issue 11's checks
            held out 60 → 64 of 210, shipped 163 → 163. An earlier version (quantile splits)
            gave held out 372.25, shipped 131.75 — and before `NOISE_PER_STEP` shipped 448.38
            (`talos_course` seed 6 2603 cells, every row 36 mm low). Each version flipped a
            seed into a whole-map failure, so it is no default. On, it costs the stereo frames'
            segmentation 1.70 → 2.43 ms a frame on `down_landing_turn` seed 1 and 1.81 → 2.12
            on the stage's seed 1 (`bench/bench_segmentation.py --speed-only --recording REC
            --tree A --tree B`, medians of 3 interleaved rounds, load 0.8–1.0).
        structure_border_px: the pixels `floor_occluding_border_px` would take out of their
            floors (with this reach) stay floor points and are marked in
            `SegmentationResult.structure_border` instead: the pipeline gives them to the heading
            estimator as structure points (`mapper.heading`), not to the maps. A floor's border
            against farther ground — a staircase's side edge, a platform's far edge — is the
            lateral end that shows a yaw error walking straight at the staircase, where its
            risers slide along themselves; the maps keep the floor's points. Same stereo model
            as `floor_occluding_border_px` (nothing without it). 0 (default): off; fogsim's
            stereo head sets 1 (`fogsim.sim.camera.noise_model.MATCHER_STRUCTURE_BORDER_PX`,
            with the figures: it harms a depth camera's heading, whose structure score works).
        tilt_max_step_t: a tilt candidate (near-horizontal plane) that fits better as itself
            with a step across its downhill direction, the step's t-statistic above this, the
            step turning its normal by more than `tilt_consensus_deg` and at least half its
            rise (`mapper.pose_correction.stepped_planes`), does not steer the tilt: it is two
            levels that noise joined (a tread and the ground beside it), and its slope is the
            step's, not the camera's. 0 (default): off (a depth camera's rows split at every
            step). For fogsim's stereo head `fogsim.sim.camera.noise_model.MATCHER_STEP_T`.
        tilt_pitch_sigma_factor: the std `mapper.tilt_filter.measured_tilt` gives the
            measured pitch (the ground normal's x in the believed robot frame) is its planes'
            fit std times this; the roll keeps the fit's (the tilt filter weighs and gates each
            axis by its own variance). 1 (default): the fit's std on both axes. Against the
            truth (`bench/tilt_calibration.py`, every 4th frame of seeds 1-4, session 39) the
            stereo head's pitch errors are 1.61-2.05 times the predicted std (robust std of
            the normalised error: stage 1.86, room 1.79, zig-zag 1.61, stairs 1.79,
            talos_course 2.05), its roll's 0.68-0.84, a depth camera's both 1.1-1.3. With
            1.8 on the stereo replays (seeds 1-8, unsafe cells mean (worst)) talos_course
            goes 51.5 (92) → 45.1 (71), the stage 2.25 (5) → 1.5 (3), the table 1.25 (5) →
            0.75 (3), but stairs 48.6 (122) → 58.4 (116), the room 8.6 (13) → 10.6 (26) and
            stage_down 3.75 (9) → 53.9 (401): the gate, wider in pitch, lets a wrong plane's
            tilt in (6-13 % of the stereo frames measure beyond it, the heavy tail the robust
            std leaves out). So it stays 1 until the tail has its own model.
    """

    min_depth_m: float = 0.05
    max_depth_m: float = 10.0
    noise_window_px: int = 6
    min_noise_m: float = 0.0005
    noise_cap_factor: float = 1.5
    tolerance_floor_m: float = 0.001
    split_sigma_factor: float = 4.0
    split_rms_sigma_factor: float = 1.3
    edge_window_px: int = 5
    edge_sigma_factor: float = 4.0
    break_sigma_factor: float = 2.0
    break_passes: int = 3
    break_reach_px: int = 3
    reassign_passes: int = 3
    grow_sigma_factor: float = 3.0
    rms_sigma_factor: float = 1.5
    fill_sigma_factor: float = 2.5
    fill_passes: int = 2
    min_segment_pixels: int = 3
    seed_min_pixels: int = 4
    min_plane_pixels: int = 20
    min_plane_extent_m: float = 0.08
    floor_max_rms_ratio: float = 1.05
    floor_max_noise_ratio: float = 0.0
    floor_roughness_m: float = 0.0
    floor_roughness_min_extent_m: float = 0.25
    ground_relabel_sigma_factor: float = 3.0
    floor_snap_sigma_factor: float = 3.0
    floor_height_tolerance_m: float = 0.005
    floor_max_segment_chi2: float = 1.0
    floor_max_normal_angle_deg: float = 5.0
    max_tilt_correction_deg: float = 20.0
    tilt_consensus_deg: float = 1.5
    expected_ground_z_m: float = 0.0
    ground_search_window_m: float = 0.05
    correct_tilt: bool = True
    correct_ground_shift: bool = True
    disparity_noise_px: float = 0.0
    stereo_baseline_m: float = 0.0
    noise_correlation_factor: float = 1.0
    floor_edge_margin_px: int = 0
    floor_height_margin_px: int = 1
    plane_refit_sigma: float = 0.0
    plane_normal_margin_px: int = 1
    floor_side_strip_px: int = 0
    floor_occluding_border_px: int = 0
    floor_occluding_border_rows_only: bool = False
    floor_occluding_border_min_width_m: float = 0.0
    floor_step_split_t: float = 0.0
    structure_border_px: int = 0
    tilt_max_step_t: float = 0.0
    tilt_pitch_sigma_factor: float = 1.0

    def __post_init__(self) -> None:
        def check(name: str, kind: type, allowed: str, ok=lambda _: True) -> None:
            check_field("SegmentationParams", name, getattr(self, name), kind, allowed, ok)

        for name in _POSITIVE_FIELDS:
            check(name, float, "a finite float > 0", lambda v: math.isfinite(v) and v > 0)
        for name in _NON_NEGATIVE_FIELDS:
            check(name, float, "a finite float >= 0", lambda v: math.isfinite(v) and v >= 0)
        for name, (lowest, highest) in _INTEGER_RANGES.items():
            if highest is None:
                check(name, int, f"an integer >= {lowest}", lambda v, lo=lowest: v >= lo)
            else:
                check(
                    name,
                    int,
                    f"an integer in [{lowest}, {highest}] (mapper.limits)",
                    lambda v, lo=lowest, hi=highest: lo <= v <= hi,
                )
        if self.min_depth_m >= self.max_depth_m:
            raise InvalidParameterError(
                f"SegmentationParams.min_depth_m ({self.min_depth_m}) must be < max_depth_m "
                f"({self.max_depth_m})"
            )
        for name in ("floor_max_normal_angle_deg", "max_tilt_correction_deg", "tilt_consensus_deg"):
            check(name, float, "in [0, 90) degrees", lambda v: 0.0 <= v < 90.0)
        check(
            "expected_ground_z_m",
            float,
            f"a finite float [m] within ±{MAX_COORDINATE_M:g} (mapper.limits.MAX_COORDINATE_M)",
            lambda v: abs(v) <= MAX_COORDINATE_M,
        )
        check(
            "noise_correlation_factor",
            float,
            "a finite float >= 1 (1: white noise)",
            lambda v: math.isfinite(v) and v >= 1.0,
        )
        if (self.disparity_noise_px > 0.0) != (self.stereo_baseline_m > 0.0):
            raise InvalidParameterError(
                f"SegmentationParams.disparity_noise_px ({self.disparity_noise_px}) and "
                f"stereo_baseline_m ({self.stereo_baseline_m}) must both be > 0 (a stereo noise "
                "model) or both 0 (none)"
            )
        for name in ("correct_tilt", "correct_ground_shift", "floor_occluding_border_rows_only"):
            check(name, bool, "a bool")

    @classmethod
    def from_mapping(cls, values: Mapping[str, float | int | bool]) -> SegmentationParams:
        """Parameters from a mapping (e.g. a scenario's ``[segmentation]`` table).

        Integral floats are accepted for integer fields; unknown keys are an error naming the
        allowed ones.
        """
        known = {f.name: f for f in fields(cls)}
        kwargs: dict[str, float | int | bool] = {}
        for key, value in values.items():
            if key not in known:
                raise InvalidParameterError(
                    f"unknown segmentation parameter {key!r}; allowed: {', '.join(sorted(known))}"
                )
            default = known[key].default
            if isinstance(default, bool):
                kwargs[key] = value
            elif isinstance(default, int) and isinstance(value, float) and value.is_integer():
                kwargs[key] = int(value)
            elif (
                isinstance(default, float)
                and isinstance(value, int)
                and not isinstance(value, bool)
            ):
                kwargs[key] = float(value)
            else:
                kwargs[key] = value
        return cls(**kwargs)


@dataclass(frozen=True)
class PlaneTable:
    """Per-plane results (index = plane id).

    Attributes:
        pixel_counts: (P,) pixels of each plane.
        heights_m: (P,) mean corrected z of the plane's points [m].
        normals: (P, 3) unit normals in the corrected robot frame (z >= 0).
        extents_m: (P, 2) footprint widths along the two in-plane axes, minor first [m].
        areas_m2: (P,) footprint area of the plane's pixels [m²].
        rms_m: (P,) RMS depth residual of the plane's pixels [m] (along the optical axis).
        is_floor: (P,) the plane is floor.
    """

    pixel_counts: NDArray[np.int64]
    heights_m: NDArray[np.float64]
    normals: NDArray[np.float64]
    extents_m: NDArray[np.float64]
    areas_m2: NDArray[np.float64]
    rms_m: NDArray[np.float64]
    is_floor: NDArray[np.bool_]

    def __len__(self) -> int:
        return int(self.pixel_counts.shape[0])


@dataclass(frozen=True)
class FloorTable:
    """Per-floor-region results (index = floor id): level regions of the image.

    Attributes:
        pixel_counts: (F,) pixels of each region.
        heights_m: (F,) weighted mean corrected z of the region's points [m].
        extents_m: (F, 2) footprint widths, minor first (sqrt(12)·std of the points moved
            onto the height along their rays) [m].
        areas_m2: (F,) footprint area of the region's pixels on a horizontal plane [m²].
        rms_ratio: (F,) RMS height residual in units of the typical noise along z (plus
            `SegmentationParams.tolerance_floor_m` in quadrature; squared residuals clipped at
            9; the ring's pixels of a neighbouring surface left out, `_foreign_rim`).
        is_floor: (F,) the region is a floor (enough pixels, wide, smooth).
    """

    pixel_counts: NDArray[np.int64]
    heights_m: NDArray[np.float64]
    extents_m: NDArray[np.float64]
    areas_m2: NDArray[np.float64]
    rms_ratio: NDArray[np.float64]
    is_floor: NDArray[np.bool_]

    def __len__(self) -> int:
        return int(self.pixel_counts.shape[0])


@dataclass(frozen=True)
class SegmentationResult:
    """Labelled range points of one depth image.

    Attributes:
        points: (N, 3) corrected robot-frame points [m] of all valid pixels, row-major order.
        floor_heights: (N,) height of the floor plane of each point [m], NaN = not floor.
        plane_ids: (N,) plane index of each point, -1 for none.
        floor_ids: (N,) floor region of each point, negative for none (-1; -3 for a floor
            region's occluding border pixel, `mapper.floor_borders`).
        pixel_index: (N,) index of each point into the flattened (height·width) image.
        correction: the tilt rotation and z shift applied.
        planes: per-plane table (free planes: they steer the tilt correction).
        floors: per-floor-region table (level regions: they give the floor heights).
        image_shape: (height, width) of the depth image.
        transform_camera_to_robot: 4×4 corrected camera pose in the robot frame.
        structure_border: (N,) True where a floor point lies on its floor's occluding border
            (`SegmentationParams.structure_border_px`, `mapper.floor_borders`): structure for
            the heading estimator; None when that is off.
    """

    points: NDArray[np.float64]
    floor_heights: NDArray[np.float64]
    plane_ids: NDArray[np.int64]
    floor_ids: NDArray[np.int64]
    pixel_index: NDArray[np.int64]
    correction: PoseCorrection
    planes: PlaneTable
    floors: FloorTable
    image_shape: tuple[int, int]
    transform_camera_to_robot: NDArray[np.float64]
    structure_border: NDArray[np.bool_] | None = None

    def labels_image(self, kind: str = "plane") -> NDArray:
        """An (H, W) picture of the result.

        Args:
            kind: "plane" → plane id per pixel (int64, -1 none, -2 no measurement);
                "floor_region" → floor region id per pixel (the same codes);
                "floor" → floor height per pixel [m] (float, NaN elsewhere).

        Raises:
            InvalidParameterError: for another kind.
        """
        size = self.image_shape[0] * self.image_shape[1]
        if kind in ("plane", "floor_region"):
            image = np.full(size, -2, dtype=np.int64)
            image[self.pixel_index] = self.plane_ids if kind == "plane" else self.floor_ids
        elif kind == "floor":
            image = np.full(size, np.nan)
            image[self.pixel_index] = self.floor_heights
        else:
            raise InvalidParameterError(
                f"labels_image kind must be 'plane', 'floor_region' or 'floor', got {kind!r}"
            )
        return image.reshape(self.image_shape)


OCCLUDING_JUMP_SIGMA = 1.0
"""How much farther (in the stereo model's inverse-depth σ) a neighbour must be to make a floor
pixel an occluding border pixel (`SegmentationParams.floor_occluding_border_px`): a 31 mm
step's edge against the ground seen past it jumps by about 1.5 σ at 1.5 m (iCub's head 0.9 m
up, baseline 68 mm: σ = 0.016 m⁻¹), a taller surface's by more."""

_DEFAULT_PARAMS = SegmentationParams()


def segment_depth(
    depth_m: NDArray[np.floating],
    intrinsics: PinholeIntrinsics,
    transform_camera_to_robot: NDArray[np.floating],
    params: SegmentationParams | None = None,
) -> SegmentationResult:
    """Segment a depth image into planes and label floor points with their plane's height.

    Args:
        depth_m: (height, width) depth along the optical axis [m]; NaN, 0 or out of
            [min_depth_m, max_depth_m] = no measurement.
        intrinsics: pinhole intrinsics of the image.
        transform_camera_to_robot: 4×4 believed camera pose in the robot frame (OpenCV camera).
        params: segmentation parameters (defaults if None).

    Returns:
        The `SegmentationResult`; an image without measurements gives an empty result.

    Raises:
        InvalidInputError: wrong shapes, complex or non-numeric data, or a transform that is
            not a rigid 4×4 matrix (`mapper.validation.rigid_transform`: a reflection or a
            shear is refused).
    """
    params = _DEFAULT_PARAMS if params is None else params
    depth = real_array(depth_m, "depth_m")
    if depth.shape != intrinsics.shape:
        raise InvalidInputError(
            f"depth_m must have shape (height, width) = {intrinsics.shape}, got {depth.shape}"
        )
    transform = _rigid_transform(transform_camera_to_robot)
    height, width = depth.shape
    pivot = transform[:3, 3].copy()
    rays_camera = intrinsics.ray_directions_camera().reshape(-1, 3)

    # NaN → invalid; depth NaN there, inv_depth its inverse.
    valid, depth, inv_depth, pixel_index = scanline.valid_depth(
        depth, params.min_depth_m, params.max_depth_m
    )
    if pixel_index.size == 0:
        return _empty_result(pivot, transform, (height, width))

    model_inv_sigma = (
        params.disparity_noise_px / (intrinsics.fx * params.stereo_baseline_m)
        if params.stereo_baseline_m > 0.0
        else 0.0
    )  # std of the inverse depth [1/m]
    # Noise, row segments, planes grown and refined, pixels filled (`scanline.fused.plane_labels`).
    (
        x,
        y,
        typical_sigma,
        local_sigma,
        seg_rows,
        seg_starts,
        seg_stops,
        labels,
        grown_labels,
        plane_table,
        counts,
    ) = scanline.plane_labels(
        inv_depth,
        valid,
        intrinsics.cx,
        intrinsics.cy,
        intrinsics.fx,
        intrinsics.fy,
        params.noise_window_px,
        params.min_noise_m,
        params.noise_cap_factor,
        model_inv_sigma,
        params.split_sigma_factor,
        params.split_rms_sigma_factor,
        params.edge_window_px,
        params.edge_sigma_factor,
        params.tolerance_floor_m,
        params.min_segment_pixels,
        params.noise_correlation_factor,
        params.break_passes,
        params.break_sigma_factor,
        params.break_reach_px,
        params.grow_sigma_factor,
        params.rms_sigma_factor,
        params.seed_min_pixels,
        params.reassign_passes,
        params.fill_sigma_factor,
        params.fill_passes,
    )
    # Dissolve small or degenerate planes and renumber the rest in creation order; their
    # geometry, and their normals refitted on their interior pixels clear of the range limit
    # and (if on) without their outliers for the tilt.
    rotation = transform[:3, :3].copy()  # C order: one compiled version of the kernels
    (
        plane_ids,
        counts,
        normals,
        centroids,
        eigen,
        areas,
        rms,
        tilt_normals,
        tilt_information,
    ) = tilt_kernels.plane_geometry(
        labels,
        grown_labels,
        pixel_index,
        counts,
        plane_table,
        rotation,
        pivot,
        rays_camera,
        depth,
        inv_depth,
        x,
        y,
        intrinsics.fx,
        intrinsics.fy,
        params.min_plane_pixels,
        params.min_noise_m,
        params.plane_normal_margin_px,
        params.plane_refit_sigma,
        1.0 / params.max_depth_m,
        params.noise_correlation_factor,
    )
    # The tilt's planes are weighted by the information of their normals (1/σ²), not by area:
    # a far plane's footprint is large while its normal, under stereo noise, is poor.
    tilt_counts = counts
    if params.tilt_max_step_t > 0.0 and params.correct_tilt and counts.size > 0:
        # Planes that are two levels joined over a hidden step do not steer the tilt.
        believed = tilt_kernels.believed_points(
            depth.reshape(-1), pixel_index, rays_camera, rotation, pivot
        )
        stepped = stepped_planes(
            believed,
            plane_ids,
            tilt_normals,
            counts,
            params.min_plane_pixels,
            math.cos(math.radians(params.max_tilt_correction_deg)),
            params.tilt_max_step_t,
            params.noise_correlation_factor,
            math.radians(params.tilt_consensus_deg),
        )
        tilt_counts = np.where(stepped, 0, counts)
    correction = estimate_tilt(tilt_normals, tilt_information, eigen, tilt_counts, pivot, params)
    centroids_c, normals_c, extents, is_floor_shape = tilt_kernels.corrected_planes(
        centroids,
        normals,
        correction.rotation,
        pivot,
        eigen,
        counts,
        math.cos(math.radians(params.floor_max_normal_angle_deg)),
        params.min_plane_pixels,
        params.min_plane_extent_m,
    )

    # Floors: level regions grown with the horizontal model in the tilt-corrected frame.
    transform_tilted = correction.transform @ transform
    origin = transform_tilted[:3, 3].copy()
    rays, points_tilted, sigma_z = scanline.level_geometry(
        depth,
        rays_camera,
        transform_tilted[:3, :3].copy(),
        origin,
        typical_sigma,
        params.min_noise_m,
    )
    floor_labels, floors = floor_regions(
        origin,
        rays,
        points_tilted,
        sigma_z,
        depth,
        (seg_rows, seg_starts, seg_stops),
        intrinsics,
        params,
    )
    if params.floor_max_noise_ratio > 0.0 and len(floors) > 0:
        noise_ratio = scanline.region_noise_ratio(
            floor_labels, local_sigma, typical_sigma, len(floors)
        )
        floors = dataclasses.replace(
            floors, is_floor=floors.is_floor & (noise_ratio <= params.floor_max_noise_ratio)
        )
    correction = ground_shift(
        correction, floors.heights_m, floors.areas_m2, floors.is_floor, params
    )
    shifted_m, floor_level_m, ground_m = tilt_kernels.shifted_floors(
        floors.heights_m,
        floors.is_floor,
        correction.z_shift_m,
        params.expected_ground_z_m,
        correction.ground_plane_found and params.ground_relabel_sigma_factor > 0.0,
    )
    # Side bands at another level leave their regions (`mapper.floor_sides`).
    point_labels = floor_labels
    if params.floor_side_strip_px > 0 and len(floors) > 0:
        point_labels, _, floor_level_m = floor_sides.peel_side_strips(
            floor_labels,
            points_tilted[..., 2] + correction.z_shift_m,
            sigma_z,
            floor_level_m,
            params.floor_side_strip_px,
            params.grow_sigma_factor,
            params.noise_correlation_factor,
            params.floor_height_tolerance_m,
            params.floor_max_rms_ratio,
        )
        shifted_m = np.where(floors.is_floor, floor_level_m, shifted_m)
    floors = FloorTable(
        pixel_counts=floors.pixel_counts,
        heights_m=shifted_m,
        extents_m=floors.extents_m,
        areas_m2=floors.areas_m2,
        rms_ratio=floors.rms_ratio,
        is_floor=floors.is_floor,
    )
    origin[2] += correction.z_shift_m
    # The near side of occluding edges (`mapper.floor_borders`): out of the floors, or marked
    # as the heading's structure (`structure_border_px`).
    borders = model_inv_sigma > 0.0 and len(floors) > 0
    jump = OCCLUDING_JUMP_SIGMA * model_inv_sigma
    if borders and params.floor_occluding_border_px > 0:
        # Floors narrower than `floor_occluding_border_min_width_m` (a sill's top) keep theirs.
        wide = floors.extents_m[:, 0] >= params.floor_occluding_border_min_width_m
        point_labels = floor_borders.occluding_border(
            point_labels,
            inv_depth,
            np.where(wide, floor_level_m, np.nan),
            params.floor_occluding_border_px,
            jump,
            params.floor_occluding_border_rows_only,
        )
    structure_border = None
    if borders and params.structure_border_px > 0:
        marked = floor_borders.occluding_border(
            point_labels, inv_depth, floor_level_m, params.structure_border_px, jump
        )
        structure_border = np.take(marked, pixel_index) == floor_borders.BORDER_LABEL
    corrected, floor_heights, floor_ids = scanline.floor_points(
        pixel_index,
        point_labels,
        floor_level_m,
        ground_m,
        rays,
        depth,
        typical_sigma,
        origin,
        params.ground_relabel_sigma_factor,
        params.floor_snap_sigma_factor,
    )

    planes = PlaneTable(
        pixel_counts=counts,
        heights_m=centroids_c[:, 2] + correction.z_shift_m,
        normals=normals_c,
        extents_m=extents,
        areas_m2=areas,
        rms_m=rms,
        is_floor=is_floor_shape,
    )
    return SegmentationResult(
        points=corrected,
        floor_heights=floor_heights,
        plane_ids=plane_ids,
        floor_ids=floor_ids,
        pixel_index=pixel_index,
        correction=correction,
        planes=planes,
        floors=floors,
        image_shape=(height, width),
        transform_camera_to_robot=correction.transform @ transform,
        structure_border=structure_border,
    )


def _rigid_transform(value: object) -> NDArray[np.float64]:
    """`rigid_transform` of ``transform_camera_to_robot``, in one kernel call when it is plain.

    A C-contiguous float64 4×4 that `tilt_kernels.clearly_rigid` accepts is returned as it is
    (what `rigid_transform` returns for it); anything else goes to `rigid_transform` (its
    verdict and its message).
    """
    if (
        type(value) is np.ndarray
        and value.dtype == np.float64
        and value.shape == (4, 4)
        and value.flags.c_contiguous
        and tilt_kernels.clearly_rigid(value, RIGID_TOLERANCE)
    ):
        return value
    return rigid_transform(value, "transform_camera_to_robot")


def floor_regions(origin, rays, points, sigma_z, depth, segments, intrinsics, params):
    """Level regions of the image (`scanline.levels.grow_floors`) and their table.

    The floor stage of `segment_depth` (public for the warm-up, which compiles it alone).

    Args:
        origin: (3,) camera centre in the tilt-corrected robot frame [m].
        rays: (H, W, 3) pixel rays in that frame with unit optical-axis component.
        points: (H, W, 3) the pixels' points in that frame [m] (NaN: no depth).
        sigma_z: (H, W) their noise along z [m].
        depth: (H, W) measured depths [m], NaN = none.
        segments: rows, starts, stops of the row segments.
        intrinsics: the camera's intrinsics (pixel footprints).
        params: segmentation parameters.

    Returns:
        (H, W) floor region of each pixel (-1: none, -2: no measurement) and the
        `FloorTable` (heights before the ground shift).
    """
    labels, counts, heights, rms, extents, areas, is_floor = scanline.level_regions(
        np.ascontiguousarray(points[..., 2]),
        sigma_z,
        points,
        rays,
        depth,
        *segments,
        origin[2],
        intrinsics.fx,
        intrinsics.fy,
        params.edge_sigma_factor,
        params.min_segment_pixels,
        params.noise_correlation_factor,
        params.grow_sigma_factor,
        params.rms_sigma_factor,
        params.floor_height_tolerance_m,
        params.seed_min_pixels,
        params.fill_sigma_factor,
        params.tolerance_floor_m,
        params.fill_passes,
        params.floor_edge_margin_px,
        params.floor_height_margin_px,
        params.floor_snap_sigma_factor,
        params.min_plane_pixels,
        params.min_plane_extent_m,
        math.tan(math.radians(params.floor_max_normal_angle_deg)),
        params.floor_max_rms_ratio,
        params.floor_max_segment_chi2,
        params.floor_roughness_m,
        params.floor_roughness_min_extent_m,
        params.floor_step_split_t,
    )
    floors = FloorTable(
        pixel_counts=counts,
        heights_m=heights,
        extents_m=extents,
        areas_m2=areas,
        rms_ratio=rms,
        is_floor=is_floor,
    )
    return labels, floors


def _foreign_rim(labels, inside, z, sigma_z, level_heights, params):
    """(H, W) bool: the pixels of the floor regions' rims that belong to a neighbouring surface.

    A pixel of its region's border ring (with `SegmentationParams.floor_height_margin_px` >= 1)
    whose height lies farther from the region's level than ``floor_snap_sigma_factor`` times
    its noise along z. Growing takes such pixels into a region one-sidedly at its border (a box
    top's side face below its rim, a riser above a tread) and `scanline.points.floor_points` takes
    their floor label away again (they are not on the region's height within the snap's
    tolerance), so they are no roughness of the region: its RMS ratio leaves them out. Inside
    the region such pixels stay roughness (a rough top's bumps).

    Args:
        labels: (H, W) floor region of each pixel (-1 none, -2 no measurement).
        inside: (H, W) bool, the pixels within their region's border ring.
        z: (H, W) the pixels' heights in the tilt-corrected frame [m].
        sigma_z: (H, W) their noise along z [m].
        level_heights: (F,) each region's level [m] (its grown segments' weighted mean).
        params: segmentation parameters.
    """
    return scanline.foreign_rim(
        labels, inside, z, sigma_z, level_heights, params.floor_snap_sigma_factor
    )


def _unit_normals(
    plane_table: NDArray[np.float64], rotation: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit normals of a plane table's planes, in the camera frame and turned up in the robot's.

    Returns:
        (P, 3) in the camera frame; (P, 3) rotated by ``rotation`` (camera to robot) and
        turned to point up (z >= 0).
    """
    normals_camera, normals, _ = tilt_kernels.unit_normals(plane_table, rotation)
    return normals_camera, normals


def _normal_sigma_deg(plane_table, correlation, min_inv_sigma=None):
    """Standard deviation of each plane's normal direction [deg] from its inverse-depth fit.

    The fit ``1/d = A·x + B·y + C`` has the covariance ``s²·M⁻¹`` (``s²`` its residual
    variance, at least ``min_inv_sigma²``; ``M`` the normal matrix; times ``correlation`` for
    correlated noise, which the residuals alone understate); the normal is ``(A, B, C)``
    normalised, so its direction varies by the covariance across it:
    ``sqrt(tr(P·C·P))/|(A, B, C)|`` with ``P`` the projection perpendicular to it.
    Degenerate planes: inf.

    Args:
        plane_table: (P, 13) `scanline.plane_pixels.plane_fits` table.
        correlation: the noise's variance inflation of means (≥ 1).
        min_inv_sigma: (P,) lower bound of each plane's inverse-depth noise [1/m] (None: 0).
    """
    if min_inv_sigma is None:
        min_inv_sigma = np.zeros(plane_table.shape[0])
    return tilt_kernels.normal_sigma_deg(plane_table, float(correlation), min_inv_sigma)


def _empty_result(pivot, transform, shape) -> SegmentationResult:
    empty_planes = PlaneTable(
        pixel_counts=np.zeros(0, dtype=np.int64),
        heights_m=np.zeros(0),
        normals=np.zeros((0, 3)),
        extents_m=np.zeros((0, 2)),
        areas_m2=np.zeros(0),
        rms_m=np.zeros(0),
        is_floor=np.zeros(0, dtype=bool),
    )
    empty_floors = FloorTable(
        pixel_counts=np.zeros(0, dtype=np.int64),
        heights_m=np.zeros(0),
        extents_m=np.zeros((0, 2)),
        areas_m2=np.zeros(0),
        rms_ratio=np.zeros(0),
        is_floor=np.zeros(0, dtype=bool),
    )
    return SegmentationResult(
        points=np.zeros((0, 3)),
        floor_heights=np.zeros(0),
        plane_ids=np.zeros(0, dtype=np.int64),
        floor_ids=np.zeros(0, dtype=np.int64),
        pixel_index=np.zeros(0, dtype=np.int64),
        correction=PoseCorrection.identity(pivot),
        planes=empty_planes,
        floors=empty_floors,
        image_shape=shape,
        transform_camera_to_robot=transform.copy(),
    )
