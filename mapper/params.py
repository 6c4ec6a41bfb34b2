"""Parameters of the floor and obstacle height map (Gutmann et al.), validated on construction.

The paper gives the grid size (100 × 100 cells of 4 cm, 16 layers of 4 cm) but no values for the
probabilities and thresholds; the defaults below are ours and each is justified in
`MapperParams`'s docstring. The required behaviours they are chosen for (DESIGN.md item 4) are
tested in ``tests/test_fog.py``.
"""

from __future__ import annotations

import math
import numbers
import reprlib
from dataclasses import dataclass

from mapper.errors import InvalidParameterError
from mapper.limits import MAX_CELL_M, MAX_CELLS, MAX_COLUMNS, MAX_COORDINATE_M, MIN_CELL_M
from mapper.validation import check_field

#: Number of 8-bit occupancy levels; level ``L`` means probability ``L / LEVELS`` (128 ↔ 0.5).
LEVELS = 256
#: The level of an unknown cell (probability exactly 0.5).
LEVEL_UNKNOWN = 128
#: The integer fields of `MapperParams`: cell and layer counts, and the pairs z matching needs.
_COUNT_FIELDS = ("nx", "ny", "nz", "zmatch_min_pairs", "floor_pass_min_rays")
#: The integer fields that may be 0: the vote caps of the floor map and the FOG's obstacle
#: margin (0 = the paper's rule).
_CAP_FIELDS = (
    "floor_vote_cap",
    "floor_frame_cap",
    "obstacle_margin_cells",
    "min_floor_neighbours",
    "min_floor_frames",
    "edge_foot_min_frames",
)


def _require(ok: bool, name: str, value: object, allowed: str) -> None:
    if not ok:
        raise InvalidParameterError(
            f"MapperParams.{name} must be {allowed}, got {reprlib.repr(value)}"
        )


@dataclass(frozen=True)
class MapperParams:
    """Grid geometry, sensor model and thresholds of the mapper.

    Every field is checked on construction (type and range): a wrong one raises
    `InvalidParameterError` naming the field, the value and what is allowed. Integer fields take
    integers, float fields any real number but a bool (never NaN; inf only for
    ``max_range_m``), ``clear_outside`` and ``discretize_rays`` only a bool.

    Attributes:
        nx: Cells along world x (robot-centred, scrolled in whole cells).
        ny: Cells along world y. ``nx * ny`` is at most `mapper.limits.MAX_COLUMNS`.
        nz: Layers of the 3D occupancy grid along z (absolute, never scrolled).
            ``nx * ny * nz`` is at most `mapper.limits.MAX_CELLS`.
        cell_m: Side of a cell in x and y [m] (paper: 0.04), in
            [`mapper.limits.MIN_CELL_M`, `mapper.limits.MAX_CELL_M`].
        layer_m: Height of a layer [m] (paper: 0.04), within the same limits.
        z_min_m: World z of the grid's lower face [m], within ±`mapper.limits.MAX_COORDINATE_M`.
            Default -0.06 puts the ground (z = 0) in
            the middle of layer 1, so ±20 mm of noise or elevation drift stay in one cell, and
            leaves one layer below the ground for holes and negative drift; with 16 layers the
            grid reaches 0.58 m, enough for surfaces up to ~0.5 m (the paper's stage tops out
            at 0.126 m).
        p_sense: Sharp sensor model constant of eqs. 12–13 (hit likelihood). 0.63: one frame
            of hits takes an unknown cell from 0.5 to 0.63 (< p_occ: a one-frame outlier is not
            trusted), two to 0.74 (occupied).
        p_occ: Occupancy threshold of eqs. 7, 8, 10 (``OG > p_occ`` is occupied). 0.65.
        p_min: Lower clamp of cell probabilities (0.07): a free cell becomes occupied again
            after five frames of hits.
        p_max: Upper clamp (0.99): a saturated cell drops below p_occ after eight frames of
            misses (0.6 s), so a removed object vanishes in bounded time while a surface seen
            for long survives a few frames of contrary rays.

            p_sense, p_occ, p_min, p_max, eps_m and nu were chosen with ``fogsim tune`` over
            the stage and box-removal recordings (README, "Tuning"; wrong cells weighted ×3):
            against hand-picked 0.7 / 0.75 / 0.12 / 0.97 / 0.02 / 0.9 the stage goes from
            96.8 % to 98.0 % of its seen cells labelled right and from −3.3 mm to −2.4 mm on its
            worst Table I row; the box of Fig. 5 clears in 9 frames instead of 4.
        eps_m: Gate of eq. 9 [m]: measurements within ±eps_m of the stored floor refer to the
            same surface. 0.01 (tuned, see p_max): twice the ±5 mm stereo noise of a plane's
            height, well below the 31 mm smallest step of the paper's staircase; a floor
            estimate that drifted low is replaced by a higher reading sooner than at 0.02.
        nu: Smoothing factor of eq. 9 (weight of the stored floor per point). 0.93 (tuned).
            Used only with ``floor_memory`` 0 (the paper's rule).
        delta_m: Obstacle threshold of eq. 11 [m]: ``h_o > h_f + delta_m`` is an obstacle,
            where ``h_o`` is the top of the highest occupied cell. 0.05 = one layer + 10 mm:
            a floor's own cells end at most one layer + its noise above it, so a flat floor
            anywhere in a cell with up to ±10 mm noise never becomes an obstacle, while any
            occupied cell lying one layer or more above the floor (its top ≥ h_f + 2 layers)
            always does, as does anything whose top is ≥ h_f + delta_m.
        free_margin_m: Rays stop clearing cells this far [m] before their end point. The
            paper's sharp model (0) clears every cell before the point's cell; at grazing
            angles — a horizontal surface seen from a standing robot — that erases the surface's
            own cells lying between the sparse samples (their spacing along the range is
            ``r·Δθ / sin(depression)``: 4 cm at 1.2 m and 17°, 16 cm at 3 m and 10° with
            88 × 72 pixels), leaving holes in floors and table tops. 0.08 (two cells) closes the
            gaps at moderate angles while rays to the ground behind a removed 7 cm box still
            cross (and clear) its cells more than 8 cm before their ends.
        max_range_m: Points farther than this from the sensor [m] are not trusted as hits
            (OctoMap's ``maxrange``): their ray clears the cells it crosses up to this range
            (and at most up to ``free_margin_m`` before the point), no hit, no floor update;
            counted in `UpdateResult.points_beyond_range`. inf: every point is a hit.
        clear_outside: Rays of points that get no hit — ends outside the grid (x, y or z) or
            beyond ``max_range_m`` — still clear the cells they cross inside the grid (True,
            as OctoMap does; the map inside the grid then does not depend on the grid's
            extent). Without it the grid's border columns and far cells collect hits from
            noisy points but are never cleared by the rays passing through them to farther
            points, and turn into false obstacles (stage: 94.5 % cells right off, 96.8 % on).
            False ignores such points (the map then depends on where the grid ends). With
            True, rays grazing over a far table edge toward the ground beyond the grid clear
            that edge's top cells in frames where no ray ends in them, as they would inside a
            larger grid.
        discretize_rays: One ray per lattice cell holding points, cast to the cell's centre
            (OctoMap's ``insertPointCloud`` with ``discretize``), instead of one ray per point.
            The end cells get their hit as before; the cells cleared differ only near the rays'
            ends, where the ray to the centre passes other cells than the rays to the points.
            The update is 1.5 times faster on the stage's 88 × 72 frames, 2.4 times at
            176 × 144 (`mapper.occupancy`). False (the exact per-point rays): over seeds 1–8
            the stage's figures are as good with it (obstacle precision 76.7 → 81.7 %, Table I
            worst row 1.30 → 1.32 mm, unsafe cells 84.6 → 84.4, both mean), box_removal's the
            same, but moving_box's ground row goes from 0.28 to 0.62 mm (worst 0.47 → 1.01).
        repeat_ray_columns: 0 (the default): every point's ray is walked whole, the exact
            insertion. ``k > 0``: a ray whose end cell an earlier point's ray of the same frame
            already hit clears only its last columns, from ``k`` columns (grid units along its
            major horizontal axis) before its stop; the first ray to each end cell is walked
            whole. Rays to one 4 cm cell differ by less than a cell far from it, and most of
            the cells a ray adds lie near its end. The stage's 88 × 72 frames (depth seed 1,
            all 832, interleaved per frame with the exact insertion, Intel Xeon, load 10-12):
            with 2 the insert takes 0.91 instead of 1.12 ms CPU (the update 1.94 instead of
            2.17), after the 832 frames 166 of 160 000 cells hold another level, no cell
            another occupied state, 1 floor height differs, no FOG type; with 6 0.98 ms, 86
            cells, no floor height (``generic`` codegen: 1.22 → 0.99 and 1.07 ms, the same
            cells; 176 × 144, 300 frames: 4.33 → 3.16 and 3.49 ms, 188 and 100 cells, 1 and 0
            occupied). Replays with 2 (seeds 1-8: stage, moving_box, stairs, box_removal depth,
            room stereo): every figure as exact but room stereo's, within 0.2 points (obstacle
            precision 48.66 → 48.50 %). The cells far from the rays' ends are cleared only by the
            first ray to each end cell, so a removed object is forgotten more slowly: against
            OctoMap's exact insertion (`tests/test_occupancy_octomap.py`, a box removed after
            12 of 30 frames) 1 to 4 columns leave one or two of its cells occupied, 6 and 8
            none. Off (0) until replays show no loss. Needs the column marks
            (`FloorObstacleMapper` ``column_marks``); no effect with ``discretize_rays``.
        zmatch_min_pairs: Matched floor points needed before a z shift is trusted (Sec. IV).
        zmatch_max_shift_m: Largest z shift [m] accepted; larger ones are reported but not
            accepted (they would mean the frame matched the wrong floor level).
        zmatch_nearest_level: Beyond the paper: when the residuals' median level lies more
            than ``2·eps_m`` from 0 and another level of at least ``zmatch_min_pairs`` pairs
            (and ``zmatch_nearest_min_share`` of the median level's) lies within ``eps_m`` of 0
            (the level a ±``eps_m`` mean shift reaches from 0: the frame agrees with the map
            there unshifted), the shift is that level's
            (`mapper.zmatch`). The robot's elevation is already corrected (elevation
            filter, height reference), so a whole frame off by a floor level is less likely
            than part of the map held at a wrong level: a surface the segmentation merged into
            the ground from far (stereo ``talos_course``: the 40 mm threshold, from the start
            pose) or mapped with a wrong tilt. With the median alone, a frame that sees mostly
            that surface is shifted onto it, its true heights never outvote the wrong ones, and
            every surface it sees next goes into the map off by as much (seeds 5 and 6: every
            row −29 and −53 mm). With the tilt filter's re-start guard (`mapper.tilt_filter`),
            stereo replays seeds 1-8, mean (worst), before → after: ``talos_course`` worst
            Table I row per seed 14.62 (53.74) → 3.80 (6.93) mm, unsafe cells 927 (3764) → 52.9
            (95); simulated_world unsafe 30.6 (231) → 25.75 (192); the zig-zag's sill 0.78
            (1.37) → 0.96 (1.79) mm, unsafe 31.5 (66) → 32.25 (71); stage, stage_down, stairs
            and room rows within 0.03 mm. Depth: 3 of 80 replays differ, by 0.01-0.02 mm on a
            row or 0.2 % of obstacle precision. Switching whenever the median's level lay
            beyond ``eps_m`` (not ``2·eps_m``) also took stereo frames whose residuals straddle
            0 (−15 / +9 mm, a tilt's near and far parts) to the wrong level (talos s7 unsafe
            39 → 1009, zig-zag s8 sill 0.78 → 6.41 mm).
        zmatch_nearest_min_share: With ``zmatch_nearest_level``, the level near 0 must also
            hold at least this share of the pairs the median's level holds (0: any level of
            ``zmatch_min_pairs`` pairs). A frame off by a whole step (the elevation a step
            behind or ahead while climbing) matches the map right at the median's level; a thin
            level near 0 is then far pairs of mixed surfaces and noise that happen to agree.
            Traced (``bench/zmatch_levels_trace.py``, stereo, frames where the rule switched):
            where the median was right (the zig-zag s1 frames 417, 609, 629, s2 540, s3 310,
            514; ``talos_course`` s1 131, 162-170) the level near 0 held 1.6-17 % of the
            median level's pairs; where the map held a surface wrong (``talos_course`` s6
            frames 79-131) mostly 29-92 % (two single frames 6-7 %: s5 94, s6 95). 0.25 lies
            in that gap. Stereo seeds 1-8, mean (worst), 0 → 0.25: zig-zag sill 0.93 (1.79) →
            0.83 (1.39) mm, unsafe 31.9 (71) → 31.75 (71) (without the nearest level: 0.82
            (1.37), 30.9 (66); the rest is seed 5, whose frames at the zig-zag's turn are tilted,
            not shifted: neither level is their shift); ``talos_course`` unsafe 52.9 (95) →
            51.5 (92), worst row per seed unchanged (6.93), threshold coverage worst 0.02 →
            0.55 (s6); room sill 1.05 (1.82) → 1.06
            (1.82) (s8 1.20 → 1.34); stage rows within 0.05 mm; simulated_world, stairs,
            stage_down, table unchanged. Depth: 4 of 96 replays differ, by 0.01-0.02 mm on a
            row.
        floor_vote_cap: Beyond the paper: the most votes a cell's stored floor height holds
            (`mapper.floor_map.update_floor`). Each floor point within ``±eps_m`` of it adds
            one, each point of another surface (higher or lower) takes one away, and the other
            surface replaces it when none is left. 0 = the paper's eq. 9 (a higher surface
            replaces at once, a lower one is ignored): there a single frame whose noise puts a
            few points of a tread into the next cell, or a rough top taken for a plane, makes
            that cell a floor at the wrong height for good. 64 points (2–6 frames of a cell at
            1–2 m): on the stage replay of seed 1 the cells unsafe go from 226 to 90 and the
            obstacle recall from 59 % to 78 % (0: 226, 8: 120, 32: 98, 64: 90), while a
            surface that really changes (a box placed on the floor) takes over within a few
            frames of being seen; a surface that disappears is removed by eq. 8 as before.
        floor_frame_cap: Beyond the paper: the most frame votes a stored floor holds
            (`mapper.floor_map.frame_verdicts`). A frame whose points at the floor's height
            (``F − eps_m <= z <= F``) are mostly not floor takes one away, one that sees the
            floor as a plane adds one; at none the floor is invalidated. 0 = off (the paper).
            On a rough box top the frames that see it rough outnumber the few that take it
            for a plane, on a real floor (stage, seed 4) almost never. 40 frames (3.2 s at
            12.5 Hz): on the stage replay of seed 4 the obstacle recall goes from 65 % to 85 %,
            the cells unsafe from 112 to 62 and the obstacle precision from 78 % to 82 %;
            with 4 or 12 a real floor seen without its plane for a while (far, or at the
            robot's feet) is lost too (obstacle precision 63 % and 75 %).
        floor_pass_fraction: Beyond the paper: a stored floor through which more than this
            fraction of the rays reaching its height in its cell passed (crossed ``z = floor``
            there and ended more than ``eps_m`` lower) does not cover its cell
            (`mapper.floor_cover`): the FOG labels the cell unknown, or obstacle where eq. 11
            finds one above the floor. A surface covering its cell stops every ray that
            reaches its height there; a step's points carried over its edge into the hidden
            cell beside it (registration error, the segmentation's snapping along the ray), or
            the sliver of a surface whose edge lies inside the cell, are passed by the rays
            reaching the rest of the cell. 0.2 (depth noise of points left unlabelled below a
            floor passes a few): on the stage replays of seeds 1–8 the unsafe cells go from
            85.8 to 41.8 (worst 131 → 84), floor precision from 99.56 % to 99.68 %, obstacle
            recall from 80.6 % to 85.6 %, floor recall and Table I unchanged, 0.6 % fewer cells
            seen; stage_down 75.8 → 25.1 (worst 107 → 57); 0.1 gives 39.9, 0.5 about half the
            gain. 0 = off (the paper).
        floor_pass_min_rays: Rays that must have reached a floor (ended on it or passed
            through it) before `floor_pass_fraction` judges it: 20, so that one or two noisy
            rays do not take a floor seen a few times. Only judged floors are affected.
        unknown_beside_obstacles: Beyond the paper: a floor is unknown when one of its 8
            neighbours is an obstacle more than ``delta_m`` above it that is no higher
            floor's edge (`mapper.fog`): the obstacle's side lies in one of the two cells, and
            the camera pose's error (stage: 23 mm median, 45 mm worst) moves it a cell either
            way from frame to frame, so the truth's "partly under the box: obstacle" cell is
            as likely the floor's (stage depth replays, seeds 1–8: 39 of the 161 unsafe cells
            were ground floors on a box's edge cell whose column never took the box). An
            obstacle whose top lies within ``delta_m`` above a stored floor within a cell of
            it is a higher floor's edge (a riser cell: its top is the next tread's layer) and
            leaves its neighbours alone: with the earlier rule (every obstacle) a tread at a
            riser's foot lost its cell (step_1's Table I coverage 98 → 79 %), now 122 → 121
            cells (stage, seeds 1–8, mean). True (default); False = the paper.
        edge_band_m: Beyond the paper: a floor is unknown when one of its 8 neighbours is a
            floor more than this below it — the rim of a raised surface — or a cell where
            nothing is stored (no floor, no obstacle) beside such a lower floor — the shadow
            behind a raised surface's side edge, seen from on top or beside it (`mapper.fog`).
            Eq. 9 keeps the highest surface, so the cell an edge crosses takes the higher
            floor, and pose error spills the higher floor's points a cell over its edge: on
            the stage depth replays (seeds 1–8) 57 of the 161 unsafe cells were the sill's
            near edge cell (1 cm of sill, 3 cm of ground) at the sill's height and 43 ground
            cells beside the platform's and treads' side edges at their height. The lower
            side is left floor (the cell at a riser's foot is floor or, by the layer rule, an
            obstacle): both sides unknown cost the treads' Table I coverage 98 → 57 %.
            0.02 m (the scores' safety tolerance), with ``unknown_beside_obstacles``, stage
            depth replays, seeds 1–8, mean (worst): unsafe cells 20.1 (57) → 2.1 (9), obstacle
            recall 93.5 (83.4) → 99.0 (95.5) %, floor precision 99.86 (99.64) → 99.98 (99.91) %,
            floor recall 99.55 → 99.54 %, Table I rows within 0.3 mm of before (worst 0.47 mm,
            as before), their cells: treads 122 → 95, platform 486 → 450, sill 50 → 44. 0 = off
            (the paper).
        narrow_rise_m: Beyond the paper, with ``edge_band_m`` > 0: a floor is unknown when
            its neighbour along x or y is a floor more than ``edge_band_m`` above it whose
            surface drops again within this distance beyond that neighbour (`mapper.fog`): the
            foot, on either side, of a raised surface at most this deep — a sill, a low box.
            Such a surface's edges lie mid-cell as often as not, and the camera pose's error
            (1–4 cm) spills each side's points a cell over the other, so the map cannot tell
            whether the lower cell at its foot holds the riser (truth: obstacle) or only the
            lower surface: measured on the stage's depth replay of seed 7, the sill's far
            edge cell (1 cm sill, 3 cm ground: truth obstacle) took 30 % of its floor points
            from the sill, the ground cell before step_1 (riser on the cell boundary: truth
            floor) 25 % from step_1. The rim rule (``edge_band_m``) already leaves the
            higher side unknown; this leaves the lower side unknown too, but only at narrow
            rises, which a walker steps over (a foot on the cell at a sill's foot stands
            partly on the sill anyway), so a staircase's treads, each leading to a higher
            one, keep the cells at their risers' feet. 0.16 m (4 cells: iCub's foot is
            0.156 m long), floored to whole cells; 0 = off. The raised surface must be at
            least two cells deep (`mapper.fog`); a cell never seen (nothing stored) after
            two of its cells ends it as a drop does — the robot's standing place before a
            sill, hidden by its feet, or a box's shadow is no evidence that it goes on — and
            the near rim of such a surface whose foot holds no floor (never seen, or only
            this surface's edge) is unknown too. Depth replays, seeds 1–8, mean (worst): stage
            unsafe cells 2.12 (9) → 1.12 (3), obstacle recall 98.96 (95.48) → 99.45
            (98.58) %; stage_down 4.75 (14) → 0.12 (1); Table I rows unchanged; coverage: the
            ground row's and a tread's lose a cell or two on some seeds (stage step_2 worst
            0.73 → 0.72) and the sill's measured edge moves (step-edge error 10 → 25 mm mean,
            30 worst, within a cell). README "Results" has every scenario.
        shadow_reach_m: Beyond the paper, with ``edge_band_m`` > 0: a floor is unknown when
            a run of cells where nothing is stored (no floor, no obstacle), at most this long,
            leads from it along x, y or a diagonal to a stored floor more than
            ``edge_band_m`` below it (`mapper.fog`): the rim of a raised surface beyond its
            shadow. A surface ``H`` high seen from a camera ``Z`` high at range ``D`` hides
            ``D·H/(Z − H)`` of the ground behind its edge (the zig-zag stage's 125 mm platform
            from 2 m at 0.85 m: 0.34 m; its 45 mm sill: 0.11 m), and pose drift spills the
            surface's points one or two cells over its side edge into that shadow, where the
            band's shadow rule (one empty cell) does not reach. 0.16 m (4 cells, as
            ``narrow_rise_m``: the shadow of the sill from 2 m, of the platform from 1 m; a
            longer run is more often a stretch never looked at than a shadow), floored to
            whole cells; 1 cell or less = off (the band's rule alone). Depth replays, seeds
            1–8, mean (worst): unsafe cells zig-zag stage 20.0 (58) → 15.0 (45), talos_course
            7.25 (23) → 0.25 (1), stage 1.12 (3) → 0.75 (2) (obstacle recall 99.45 → 99.63 %);
            floor recall −0.01 to −0.03 points (a raised surface's rim before a wide shadow is
            given up as the band gives up one beside a lower floor: the platforms' Table I
            coverage 0.90–0.92 → 0.86–0.87, the room's sill 0.43 → 0.38); Table I rows
            within 0.01 mm; stage_down, table, moving_box and box_removal unchanged.
        min_floor_neighbours: Beyond the paper, with ``edge_band_m`` > 0: a floor that the
            other rules leave a floor is unknown when fewer than this many of its 8 neighbours
            are floors within ``edge_band_m`` of it and one of them is an obstacle higher than
            it (`mapper.fog`): a patch of one or two cells inside something taller — depth
            noise fits a plane to a rough top's lower part — on which no foot fits. 2 takes a
            patch of one or two cells (the stage's rough box tops: 3 unsafe cells on seeds 3
            and 8); a strip of three keeps its middle cell. With ``shadow_reach_m`` 0.16,
            replays seeds 1–8, mean (worst), 0 → 2: unsafe cells, depth: stage 0.75 (2) →
            0.38 (2), room 2.50 (6) → 1.50 (6), moving_box 8.88 (12) → 6.62 (10),
            talos_course 0.25 → 0.12, zig-zag stage 15.00 → 14.75; stereo: stage 8.25 (15) →
            7.75 (14), zig-zag stage 42.25 (75) → 39.75 (74); obstacle recall up to +0.8
            points, floor recall within 0.01 point, Table I worst rows unchanged (the stereo
            zig-zag sill's mean 0.84 → 0.94 mm, its worst 1.76 as before); the other sets
            unchanged — but on the room's stereo replays the sill, 3 cells deep and patchy
            under stereo noise, loses cells (seed 4: 29 → 17, its row −1.55 → −2.00 mm; the
            worst row over seeds 1.82 → 2.00 mm), more than the +0.1 mm allowed, so it is off:
            0 (the default) = off; 2 where rough tops matter more than thin sills. 1 (a floor
            cell with no floor neighbour within the band, beside a taller obstacle; session
            34, with `HeadingParams.first_estimate_every` 1, seeds 1–8): depth unsafe cells
            stage 0.12 (1) → 0, room 1.38 → 1.0, moving_box 8.9 → 8.5, talos_course 0.25 →
            0.12, stereo room 9.75 → 8.25, stage 5.1 → 4.75, zig-zag stage 32.5 → 31.4, rows
            unchanged — but the zig-zag stage's stereo sill (patchy: 18 % of its cells have a
            floor) kept one wrong cell on seed 8: its row 0.3 → 16 mm. Off too.
        min_floor_frames: Beyond the paper, with ``floor_frame_cap`` > 0: a floor holding
            fewer than this many frame votes (the frames that saw it as a plane, less those
            that saw no plane at its height: `mapper.floor_map.frame_verdicts`) is unknown
            when no neighbour holds a floor within ``edge_band_m`` of it with this many votes
            and two opposite neighbours hold no floor and an obstacle top no lower than
            ``eps_m`` below it (it lies inside something, not at its edge;
            `mapper.fog.mark_unconfirmed_floors`; output only, after every other rule): a
            level patch of a rough top that one frame's noise let pass the segmentation's
            floor tests, which another frame rarely confirms (each frame's patch lies
            elsewhere on the top, at another height), and which the last frames of a run
            leave in the map with nobody to take it away. 2 (one confirmation); 0 or 1 =
            off. Replays, seeds 1–8, off → 2, mean (worst): unsafe cells stage depth with
            `HeadingParams.first_estimate_every` 1: 0.125 (1) → 0 (seed 3: the last frame's
            patch on box_right_2 at 163 mm); stereo zig-zag 32.5 → 31.9, room 9.75 → 9.0,
            stage 5.12 → 5.0, depth eth_stairs 5.88 → 5.12, talos_course 0.25 → 0.12, none
            worse, worst cases unchanged; obstacle recall up to +0.4 point; floor recall
            eth_stairs 29.80 → 29.47 % (worst 27.19 → 26.55: terrain treads seen by one frame
            between their risers' columns), elsewhere within 0.001 point; Table I rows
            unchanged but room stereo's sill (coverage 0.219 → 0.217, mean error 1.015 →
            1.016 mm, worst rows as before). Without the opposite pair (one such neighbour
            enough): eth_stairs floor recall −0.75 point, table −0.2 point worst.
        rim_over_spill: Beyond the paper, with ``edge_band_m`` > 0: the rim rule counts a
            neighbour that eq. 11 labels obstacle when its stored floor lies more than
            ``edge_band_m`` below the floor beside it, its top reaches no higher than that
            floor + ``delta_m`` (`mapper.fog`: a lower surface under the raised surface's own
            spilled points, one layer up), and the raised floor ends across from it: the cell
            on the other side holds no floor and its top lies within ``delta_m`` above the
            floor (the surface's own layer: a rough top's column), or, along x or y, a lower
            floor (a single raised cell). The rim rule looked only at neighbours labelled
            floor, so a raised cell beside such a cell stayed a floor, though it may be a rough
            top's low patch beside a box's edge (stage depth seed 3: 163 mm on box_right_2,
            whose true top is 220 mm) or ground that took a spilled surface's height (stereo).
            A riser's edge cell holds the lower tread's floor under the upper tread's layer
            just as a spill does; the upper tread goes on across from it, so its first row
            stays a floor (without that condition, session 30: talos_course floor recall 96.50
            → 96.42 %, every tread's first row lost). Something taller than the floor +
            ``delta_m`` is no spill of it and is left to ``unknown_beside_obstacles``; across
            a surface at most ``narrow_rise_m`` deep (a sill between two such cells) the rule
            is off: the narrow-rise rules judge it. Replays seeds 1–8 (session 31), False →
            True, mean (worst): unsafe cells, depth: stage 0.12 (1) → 0 on every seed, room
            1.88 (5) → 1.50 (5), the other depth sets unchanged (talos_course, stairs: maps
            bit-identical to off); stereo: stage 5.75 (10) → 5.12 (8), stage_down 11.25 (34) → 10.50
            (32), zig-zag stage 40.38 (75) → 39.75 (75), room 11.88 (20) → 9.75 (16); floor
            recall within 0.01 point, obstacle recall up to +0.8 point, floor precision
            better or equal, Table I worst rows unchanged. Coverage given up: the room's
            stereo sill 32.0 → 26.2 cells a run (its row 1.02 mm as before), the zig-zag
            stage's sill 37.0 → 33.9 (depth) and 17.4 → 15.6 (stereo, its mean 0.64 → 0.80
            mm, worst 1.37 as before), treads within a cell. True (the default); False: the
            rim rule looks at floor-labelled neighbours only.
        rim_over_seen_drop: Beyond the paper, with ``edge_band_m`` > 0: a floor is unknown
            beside a cell where nothing is stored (no floor, no obstacle) whose column holds a
            layer observed free more than ``edge_band_m`` below the floor (`mapper.fog`):
            rays passed under the surface's height there, so the surface ends — the rim
            before a drop whose bottom was never seen. Every other rim rule looks for a lower
            floor (beside it, or past a shadow up to ``shadow_reach_m``); behind a raised
            surface's side edge the ground may never be seen at all (the zig-zag stage's
            platform: the robot never looks past its sides), and pose drift spills the
            surface's points a cell over that edge, where they make a floor at its height
            over the ground. The band keeps the ground's cells: the layer under the ground's
            is cleared by rays to noisy points below the ground. Replays seeds 1–8 (session
            31, with ``rim_over_spill``), False → True, mean (worst): unsafe cells zig-zag
            stage 14.75 (45) → 11.25 (44) in depth, 39.75 (75) → 32.50 (70) in stereo, every
            other set unchanged; floor recall within 0.01 point (stage and room stereo −0.01),
            Table I rows unchanged but the zig-zag depth sill's mean (0.04 → 0.05 mm). Cost:
            the platforms' rims before their unseen sides — Table I cells a run: zig-zag
            platform 687 → 684 (depth), 704 → 694 (stereo), the stage's stereo platform 439 →
            435 — and a few ground cells measured above 0 beside cells never seen (4–16 a run
            of 5 000–10 000). Counting only layers more than two bands below lost every gain
            (zig-zag depth 14.75 as off): the 125 mm platform's evidence is the layer right
            under it.
        ground_noise_unknown: Beyond the paper: a cell eq. 11 makes an obstacle is unknown when its
            top (eq. 10) lies no more than ``delta_m`` above the lowest floor of its 8 neighbours
            that eq. 11 leaves a floor, at least 3 of them (`mapper.fog`): nothing in it stands more
            than δ above the floor around it, only its own floor is missing (far or noisy ground the
            segmentation left unlabelled, whose hits fill the ground's layer) or lower than every
            neighbour's (a stereo outlier) — noise, not an obstacle; eq. 11 with a missing floor
            counts every occupied cell. A cell with fewer such floors around it (inside an obstacle,
            beside floors with something on them, a rough top's cell beside a small plane fitted to
            it) is left to eq. 11. Unknown, not floor: the cell's own surface was not measured; and
            only in the output: the rim rules see eq. 11's obstacle, so no floor is added anywhere.
            Replays seeds 1–8 (session 32), False → True, cells taken from obstacle to unknown a
            run, truth floor / truth obstacle: room stereo 54.0 / 6.5, zig-zag stage stereo 43.8 /
            6.1, stage stereo 28.8 / 1.6, talos_course 21.4 / 0, stairs 15.9 / 0, room 12.3 / 1.5,
            stage_down stereo 8.0 / 10.0 (its sill's edge cells holding only ground hits), zig-zag
            stage 7.8 / 2.8, stage 3.5 / 1.0; obstacle precision room stereo 48.7 → 54.0 %, zig-zag
            stereo 41.9 → 45.3 %, stage stereo 57.1 → 61.8 %, obstacle recall at most 0.17 point
            lower (zig-zag stereo 95.95 → 95.78 %); every floor label, Table I row and unsafe cell
            the same on every set and seed. (The report's floor recall, over the labelled cells,
            rises with the obstacles taken out of its denominator: room stereo 95.6 → 96.5 %.) True
            (the default); False: the paper's eq. 11.
        obstacle_margin_cells: Beyond the paper: eq. 11 compares a cell's floor with the
            highest obstacle top (eq. 10) within this many cells of it (`mapper.fog`), so a
            floor beside something more than ``delta_m`` above it is an obstacle. The truth
            (DESIGN.md) makes a cell an obstacle when an edge crosses it; a sill's or box's
            edge 1 cm inside a cell leaves most of the cell's points on the lower surface, and
            the map cannot place an edge within a cell (a riser on a cell boundary gives the
            same points: pose error and the segmentation's snapping carry points ~1 cm
            across). 0 (the paper's eq. 11, the default). 1 (the 8 neighbours), replays of
            seeds 1–8, depth, mean (worst): stage unsafe cells 44.2 (72) → 23.0 (38),
            obstacle recall 85.7 (74.7) → 94.4 (89.5) %, floor precision 99.7 → 99.9 %, but
            floor recall 99.4 → 97.1 %, cells right 99.1 → 97.0 %, obstacle precision 75.6 →
            41.4 % (the floor at the foot of every riser taller than the layer rule allows —
            31→61 mm but not 61→92 mm — and around every obstacle turns obstacle), and a
            tread's Table I row loses the cells beside the next riser: stage rows move
            ≤ 0.01 mm, stage_down's step_1 0.65 mm on seed 3, room's sill 0.55 mm on seed 8.
        raised_rim_obstacle: Beyond the paper: a floor beside a stored floor more than
            ``delta_m`` below it (the rim of a rise too high for eq. 11 to call floor) is an
            obstacle (`mapper.fog.mark_raised_rims`): the edge lies in one of the two cells and the
            camera pose's error moves it a cell either way; with ``obstacle_margin_cells`` ≥ 1
            the cell at the rise's foot is an obstacle too. False (default: the paper); True
            with ``obstacle_margin_cells = 1`` is a safety margin of a cell on either side of
            an obstacle-sized rise (moving_box depth replays, seeds 1–8: see the README's
            "Known limitations").
        floor_memory: Beyond the paper: a height within ``±eps_m`` of the stored floor is
            averaged in as one frame's measurement, the stored height being the weighted mean
            of the frames since it was stored, its weight capped at this many frames (at
            `mapper.floor_map.WEIGHT_RANGE_M`), so the mean forgets at that rate
            (`mapper.floor_map.update_floor`). 0 = the paper's eq. 9, ``nu`` per point, which
            keeps mostly the last one or two frames' height. A surface's height scatters by
            3.7 mm (SD) from frame to frame at 1.0–1.3 m on the stage's stereo replays, by
            7.5 mm at 1.6–2 m (mostly the camera pose's error; lag-one autocorrelation 0–0.3).
            8 frames (0.64 s): stereo stage replays, seeds 1–8, the worst Table I row per seed
            3.45 mm on average (worst 5.50, the sill on seed 4) with 0 → 2.82 (3.47) with 8
            (with range power 4; 2.78 (3.56) with power 2), 3.17 (3.94) with 16, 3.37 (4.24)
            with 32 (power 2): a longer memory keeps more of the far frames, whose heights
            read low (the segmentation's part: −0.7 mm at 1.0–1.3 m, −2.7 at 2.4–2.8 m), so
            the steps come out lower. Depth replays: box_removal and moving_box's events and
            rows as with 0.
        floor_range_power: Beyond the paper: with ``floor_memory``, a frame's measurement
            at range ``r`` [m] weighs ``(WEIGHT_RANGE_M / r)^floor_range_power`` (at most 1).
            4: the variance of stereo depth grows as ``z^4`` (constant disparity noise).
        above_top_reach_m: Beyond the paper: points more than ``delta_m`` and at most this
            far above the grid's top [m] (`z_max_m`) mark their column as holding something
            above the grid, rays crossing the top face downwards clear it, and the FOG calls
            such a column an obstacle at the grid's top (`mapper.above_top`): a surface
            rising out of the grid (a staircase seen from its bottom) is no floor of the
            tread at its foot. 0.6: up to 1.18 m with the default grid, above iCub's head (a
            ceiling higher up is no rise for it). Suites, seeds 1–8 (session 39), 0 → 0.6,
            mean (worst): `eth_stairs` stereo unsafe cells 38.5 (52) → 23.0 (47), obstacle
            recall 90.1 → 98.5 %, floor precision 97.3 → 99.3 %, floor recall 48.6 → 47.8 %;
            depth obstacle recall 98.7 → 99.3 %, obstacle precision 13.5 → 22.1 %, unsafe
            cells 5.1 (13) as before; `simulated_world` and `table` stereo floor recall −0.07
            and −0.09 points, obstacle precision −0.7 and −0.3 points; every other figure
            of both suites the same. 0 or at most ``delta_m``: off, the paper's grid.
        edge_split_share: Beyond the paper: a floor is unknown when at least this share of
            the frames that gave its column two floor points or more split it — floor points
            of planes more than ``edge_split_gap_m`` apart, the stored floor above the lower
            one — (and at least 2 such frames), and the column stands out across its
            neighbours (``edge_split_contrast``): a step's edge runs through the cell
            (`mapper.floor_edges`), which the truth calls an obstacle and the floor map would
            give one tread's height. Output only. 0 (with ``edge_split_lower_share`` 0) = off.
            0.2, 0.3 and 3, chosen on replays of `stage_offgrid` and an off-lattice `stairs`
            (seeds 1–4, depth and stereo) and of the shipped stage, room and zig-zag stage
            (never the held-out scenes): unsafe cells 547 → 418 over those 21 runs for 56
            right floor cells left unknown (the room's sill 7, the stage 13); without the
            contrast, shares 0.2 and 0.6 took 423 for 339 (the room's sill coverage 37 → 6 %).
            The suites' figures: README "Cells that straddle an edge".
        edge_split_lower_share: The same for the frames that split a column whose stored floor
            is the lower plane (a tread's last column holding part of the next tread); 0 = off.
        edge_split_gap_m: The spread of plane heights [m] within one column of one frame that
            splits it (`mapper.floor_edges`): above the 1–15 mm noise puts between fragments of
            one surface's planes, below the scenes' lowest riser (25 mm).
        edge_split_contrast: With the shares: a column counts only where it was split at
            least this many times as often as both its neighbours along x, y or a diagonal
            (`mapper.floor_edges.mark_floor_edges`). A riser on a cell boundary splits the
            columns on both its sides about as often (the pose's 1–2 cm error carries each
            plane's points across; stage depth seed 1: 86 and 110 split frames), a riser inside
            a column splits that column far more often than its neighbours (`stage_offgrid`:
            160 against 13 and 32). 0 = the shares alone.
        edge_foot_min_frames: Beyond the paper, with ``floor_frame_cap`` > 0: a floor that
            fewer than this many frames confirmed (its frame votes) is unknown when one of its
            8 neighbours holds a floor more than ``edge_band_m`` (``eps_m`` with the band off)
            above it (`mapper.floor_edges.mark_floor_edges`; output only, after the split rule): the
            lower side of a side edge, whose cell may hold the raised surface and whose
            ground the frames saw only from afar (`stage_offgrid`, depth seed 1: 1–4 frames
            against 40 around it). 8, chosen on the 17 replays of the split rule's tuning set
            (never the held-out scenes): unsafe cells 322 → 275 for 177 right floor cells
            left unknown (4: 293 for 121, 16: 268 for 260). The suites' figures: README
            "Cells that straddle an edge". 0 = off.
        uncovered_rims: Beyond the paper, with ``floor_pass_fraction`` > 0: a floor is unknown
            when its neighbour along x or y holds its surface's last stored floor (the cell
            beyond holds no floor of that height), which the cover check finds does not cover
            its cell, in a column no frame split, and the surface goes on for
            `narrow_rise_cells` cells the other way (`mapper.floor_edges.mark_floor_edges`;
            output only, after the weak-foot rule): the raised surface's points reach past its
            side edge, so the edge lies about there — in the uncovered cell or, with the
            odometry's sideways drift (2–3 cm by the stage's platform), in the floor beside it
            (`stage_offgrid` depth seed 3: the platform's map a cell wide of its side, the
            cell holding the edge a floor at the platform's height). On the 17 replays of the
            tuning set (never the held-out scenes; after the weak-foot rule): unsafe cells
            275 → 163 for 529 right floor cells left unknown. Built up: every uncovered
            neighbour of the same height took 275 → 116 for 1673 (the stage's sill coverage
            80 → 28 %), leaving out the split columns 151 for 1195, then asking the surface to
            go on 4 cells 159 for 917, then the neighbour to be its last column 163 for 529.
            The suites' figures: README "Cells that straddle an edge". The split frames are
            counted only with ``edge_split_share`` or ``edge_split_lower_share`` > 0; without
            them every column counts as unsplit. False = off.
    """

    nx: int = 100
    ny: int = 100
    nz: int = 16
    cell_m: float = 0.04
    layer_m: float = 0.04
    z_min_m: float = -0.06
    p_sense: float = 0.63
    p_occ: float = 0.65
    p_min: float = 0.07
    p_max: float = 0.99
    eps_m: float = 0.01
    nu: float = 0.93
    delta_m: float = 0.05
    free_margin_m: float = 0.08
    max_range_m: float = math.inf
    clear_outside: bool = True
    zmatch_min_pairs: int = 30
    zmatch_max_shift_m: float = 0.08
    zmatch_nearest_level: bool = True
    zmatch_nearest_min_share: float = 0.25
    floor_vote_cap: int = 64
    floor_frame_cap: int = 40
    discretize_rays: bool = False
    repeat_ray_columns: int = 0
    floor_pass_fraction: float = 0.2
    floor_pass_min_rays: int = 20
    unknown_beside_obstacles: bool = True
    edge_band_m: float = 0.02
    narrow_rise_m: float = 0.16
    shadow_reach_m: float = 0.16
    min_floor_neighbours: int = 0
    min_floor_frames: int = 2
    rim_over_spill: bool = True
    rim_over_seen_drop: bool = True
    ground_noise_unknown: bool = True
    obstacle_margin_cells: int = 0
    raised_rim_obstacle: bool = False
    floor_memory: float = 8.0
    floor_range_power: float = 4.0
    above_top_reach_m: float = 0.6
    edge_split_share: float = 0.2
    edge_split_gap_m: float = 0.015
    edge_split_lower_share: float = 0.3
    edge_split_contrast: float = 3.0
    edge_foot_min_frames: int = 8
    uncovered_rims: bool = True

    def __post_init__(self) -> None:
        def check(name: str, kind: type, allowed: str, ok=lambda _: True) -> None:
            check_field("MapperParams", name, getattr(self, name), kind, allowed, ok)

        for name in _COUNT_FIELDS:
            check(name, int, "a positive int", lambda v: v > 0)
        _require(
            self.nx * self.ny <= MAX_COLUMNS,
            "nx*ny",
            self.nx * self.ny,
            f"at most {MAX_COLUMNS} columns (mapper.limits.MAX_COLUMNS)",
        )
        _require(
            self.cell_count <= MAX_CELLS,
            "nx*ny*nz",
            self.cell_count,
            f"at most {MAX_CELLS} cells (mapper.limits.MAX_CELLS)",
        )
        for name in ("cell_m", "layer_m"):
            check(
                name,
                float,
                f"a float > 0 [m] in [{MIN_CELL_M}, {MAX_CELL_M}] (mapper.limits)",
                lambda v: MIN_CELL_M <= v <= MAX_CELL_M,
            )
        check(
            "z_min_m",
            float,
            f"a finite float [m] within ±{MAX_COORDINATE_M:g} (mapper.limits.MAX_COORDINATE_M)",
            lambda v: abs(v) <= MAX_COORDINATE_M,
        )
        check("p_occ", float, "in (0.5, 1)", lambda v: 0.5 < v < 1.0)
        check("p_sense", float, "in (0.5, 1)", lambda v: 0.5 < v < 1.0)
        check("p_min", float, "in (0, 0.5)", lambda v: 0.0 < v < 0.5)
        check("p_max", float, "in (0.5, 1)", lambda v: 0.5 < v < 1.0)
        check("nu", float, "in [0, 1]", lambda v: 0.0 <= v <= 1.0)
        check("floor_pass_fraction", float, "in [0, 1) (0: off)", lambda v: 0.0 <= v < 1.0)
        for name in ("edge_split_share", "edge_split_lower_share"):
            check(name, float, "in [0, 1] (0: off)", lambda v: 0.0 <= v <= 1.0)
        check(
            "floor_memory",
            float,
            "a finite float >= 0 [frames] (0: the paper's smoothing by nu)",
            lambda v: math.isfinite(v) and v >= 0,
        )
        check(
            "floor_range_power",
            float,
            "a finite float >= 0",
            lambda v: math.isfinite(v) and v >= 0,
        )
        for name in (
            "eps_m",
            "delta_m",
            "free_margin_m",
            "edge_band_m",
            "narrow_rise_m",
            "shadow_reach_m",
            "above_top_reach_m",
            "edge_split_gap_m",
        ):
            check(name, float, "a finite float >= 0 [m]", lambda v: math.isfinite(v) and v >= 0)
        check(
            "edge_split_contrast",
            float,
            "a finite float >= 0 (0: the shares alone)",
            lambda v: math.isfinite(v) and v >= 0,
        )
        check("max_range_m", float, "a float > 0 [m] (inf: no limit)", lambda v: v > 0)
        for name in (
            "clear_outside",
            "discretize_rays",
            "unknown_beside_obstacles",
            "raised_rim_obstacle",
            "rim_over_spill",
            "rim_over_seen_drop",
            "ground_noise_unknown",
            "zmatch_nearest_level",
            "uncovered_rims",
        ):
            check(name, bool, "a bool")
        for name in _CAP_FIELDS:
            check(name, int, "an int >= 0 (0: the paper's rule)", lambda v: v >= 0)
        _require(
            self.floor_frame_cap == 0 or self.min_floor_frames <= self.floor_frame_cap,
            "min_floor_frames",
            self.min_floor_frames,
            f"at most floor_frame_cap ({self.floor_frame_cap}): a floor holds no more votes",
        )
        _require(
            self.floor_frame_cap == 0 or self.edge_foot_min_frames <= self.floor_frame_cap,
            "edge_foot_min_frames",
            self.edge_foot_min_frames,
            f"at most floor_frame_cap ({self.floor_frame_cap}): a floor holds no more votes",
        )
        check(
            "repeat_ray_columns",
            int,
            "an int >= 0 (0: every ray walked whole, the exact insertion)",
            lambda v: v >= 0,
        )
        _require(
            self.obstacle_margin_cells < min(self.nx, self.ny),
            "obstacle_margin_cells",
            self.obstacle_margin_cells,
            f"below min(nx, ny) = {min(self.nx, self.ny)}",
        )
        check(
            "zmatch_nearest_min_share",
            float,
            "a finite float >= 0 (0: any level of zmatch_min_pairs pairs)",
            lambda v: math.isfinite(v) and v >= 0,
        )
        check(
            "zmatch_max_shift_m",
            float,
            "a finite float > 0 [m]",
            lambda v: math.isfinite(v) and v > 0,
        )
        _require(
            self.occ_threshold_level < self.level_max,
            "p_occ",
            self.p_occ,
            f"below p_max={self.p_max} after 8-bit quantisation",
        )

    @property
    def extent_x_m(self) -> float:
        """Side of the grid along x [m]."""
        return self.nx * self.cell_m

    @property
    def extent_y_m(self) -> float:
        """Side of the grid along y [m]."""
        return self.ny * self.cell_m

    @property
    def z_max_m(self) -> float:
        """World z of the grid's upper face [m]."""
        return self.z_min_m + self.nz * self.layer_m

    @property
    def splits_edges(self) -> bool:
        """Whether the split rule is on (either share > 0): the split frames are counted."""
        return self.edge_split_share > 0.0 or self.edge_split_lower_share > 0.0

    @property
    def weak_foot_frames(self) -> int:
        """`edge_foot_min_frames` as the FOG reads it: 0 (off) without frame votes."""
        return self.edge_foot_min_frames if self.floor_frame_cap > 0 else 0

    @property
    def judges_uncovered_rims(self) -> bool:
        """Whether `uncovered_rims` applies: it needs the cover check (`floor_pass_fraction`)."""
        return self.uncovered_rims and self.floor_pass_fraction > 0.0

    @property
    def narrow_rise_cells(self) -> int:
        """`narrow_rise_m` in whole cells (floored; 0 = off), as the FOG reads it."""
        return math.floor(self.narrow_rise_m / self.cell_m + 1e-9)

    @property
    def shadow_reach_cells(self) -> int:
        """`shadow_reach_m` in whole cells (floored; 0 or 1 = off), as the FOG reads it."""
        return math.floor(self.shadow_reach_m / self.cell_m + 1e-9)

    @property
    def cell_count(self) -> int:
        """Cells of the 3D grid."""
        return self.nx * self.ny * self.nz

    @property
    def level_min(self) -> int:
        """Lowest 8-bit level a cell can reach: the smallest ``L`` with ``L/256 >= p_min``."""
        return math.ceil(self.p_min * LEVELS)

    @property
    def level_max(self) -> int:
        """Highest 8-bit level: the largest ``L <= 255`` with ``L/256 <= p_max``."""
        return min(LEVELS - 1, math.floor(self.p_max * LEVELS))

    @property
    def occ_threshold_level(self) -> int:
        """A cell is occupied (``p > p_occ``) iff its level is strictly above this one."""
        return math.floor(self.p_occ * LEVELS)

    def with_overrides(self, **changes: float) -> MapperParams:
        """Copy with some fields replaced (validated); unknown names raise a ValueError."""
        fields = set(self.__dataclass_fields__)
        unknown = sorted(set(changes) - fields)
        if unknown:
            raise InvalidParameterError(
                f"unknown MapperParams field(s) {unknown}; allowed: {sorted(fields)}"
            )
        values = {name: getattr(self, name) for name in fields}
        for name, value in changes.items():
            number = isinstance(value, numbers.Real) and not isinstance(value, bool)
            if name in (*_COUNT_FIELDS, *_CAP_FIELDS) and number and float(value).is_integer():
                value = int(value)
            if name == "clear_outside" and number and value in (0, 1):
                value = bool(value)
            values[name] = value
        return MapperParams(**values)
