"""The camera height reference, estimated over frames from the ground under the robot's feet.

The paper (Sec. IV) shifts each frame's data so that "the plane that is closest to an expected
ground plane" lies on it. One frame's choice is fragile: depth noise splits the ground into
fragments millimetres apart, a sliver or a stair tread can lie nearer the expected height than
the ground, and when the robot starts on a platform the surface under its feet is not in view
at all. Whatever the first frames choose, z-matching carries it through the whole run.

What the segmentation's ground shift corrects is the error of the camera's height in the robot
frame R (origin on the ground below the robot), which the joint encoders cause: a neck bias of a
few degrees moves the camera by millimetres, nearly the same in every frame of a run (on the
stage: −14 to +6 mm between seeds, about 1 mm frame to frame). So this module estimates one
shift for the run from many frames and applies it to every frame:

- a frame *measures* the shift when one of its floor regions (level regions of the segmentation,
  heights in the tilt-corrected frame R before any shift) is large enough to be the ground around
  the robot (`min_area_m2`: larger than any stair tread or sill top, so neither can be taken for
  it) and lies within `gate_m` of where the ground must be: the kinematic prior (height 0: the
  feet stand on it) until the estimate has converged, the estimate afterwards. Of several such
  regions the largest (the most precise height) is measured. While the robot still stands at
  its start level (odometry's z within `start_level_m` of the start pose's) and the estimate has
  not converged, a region of at least `start_min_area_m2` (only the ground around the robot
  is that large) is a candidate up to `start_gate_m` from the prior: a neck error of the
  paper's 7° puts the camera up to 24 mm off (stage, seed 2), and the 20 mm gate then took a
  0.31 m² patch of the first step for the ground (every row −31 mm). Walking down still needs
  the narrow gate (a tread's ground 31 mm below the feet), so the wide one ends at the first
  step;
- the estimate is the median of the measurements made at the lowest level the robot has stood
  on (odometry's z within `start_level_m` of its lowest so far): one wrong frame cannot move
  it, and a frame on a tread, which can take the large surface one rise below its feet for the
  ground under them when the encoders' error and the sensor's noise put it inside the gate,
  is outvoted as soon as the robot stands lower (stereo, stage_down seed 5: five frames on
  the first step measured the ground below it at +12 … +20 mm, the frames on the ground then
  −9 … +7 mm, and the median of the first 8 measurements, +12 mm, put every row +3 to +9 mm
  off). It has *converged* after `min_frames` such measurements (from then on the gate
  centres on it);
- measured below the start level (walking down), the waiting frames are mapped only when the
  estimate is also *precise*: the median's
  standard error, from the measurements' own scatter (1.2533 · 1.4826 · MAD / √n), is at most
  `known_error_m`. Every frame mapped later is anchored to what the waiting frames made of
  the ground (`start_surface_m` below), so the estimate they were mapped with is the map's
  offset for the whole run. Depth measures a frame's ground to about a millimetre and 8
  frames suffice; stereo scatters by 4-6 mm a frame, and the median of the first 8 on the
  ground was 0.5-3 mm off the camera's true height error (stage_down, stereo, seeds 1-8:
  every row of a seed off by as much, the worst 3.95 mm, while the median of all the run's
  measurements was within 0.4 mm on every seed). The frames then wait for about 60-130
  measurements. At the start level the map is anchored to the start pose's z, exact by the
  kinematics, and `min_frames` suffice (stereo, stage: waiting longer put the ground 0.5 mm
  further off);
- a frame is shifted by its *own* measurement when that lies within `frame_gate_m` of the
  estimate (`frame_shift_m`): it saw the ground the estimate was made of, and the encoders'
  noise moves the camera by about a millimetre from frame to frame, which one shift for the run
  cannot follow (flat_floor, seeds 1-8: the map's ground 0.39 mm mean, 0.62 mm worst off with
  the estimate alone; the stage's worst row 2.58 → 0.97 mm). Any other frame takes the
  estimate;
- until it is known (`known`) the caller defers the frames
  and maps them once it is (mapping them earlier would freeze an unconverged reference into
  the map). After `max_wait_frames` frames without convergence the kinematics alone are
  trusted (shift 0, or the median so far), so a robot that never sees the surface under its
  feet still maps — with the encoders' error.

Walking down from the start, the frames wait while odometry's z drifts (foot-to-foot kinematics:
stage_down, seeds 1-8, −1 to −4 mm by the time the robot stands on the ground), and the
elevation filter, which follows the map under the robot, cannot see it: those frames built that
map. The surface the robot arrives on was already seen from the start, where odometry is exact,
so `arrival_drift_m` measures the drift as the slope of the heights at which the waiting frames
saw that surface over the way walked (their camera height error, which they could not measure
with the surface under their feet out of view, is the same in all of them and drops out);
still at the start level, the surface under the feet is the start surface, at the start pose's
z by the kinematics, and the drift is odometry's change. The caller takes it out of the waiting
frames (growing from 0 at the start) and of the robot's elevation from then on.

The same holds for the rest of the run: the elevation filter follows the map under the robot,
and the map ahead of the robot is made by the frames just before, so a small lag of the filter
behind odometry's drift goes into the map and from there into the robot's elevation again
(stairs, seed 7: the ground 2 mm low after 100 frames of level walking, every frame measuring
it at the feet). A frame that measured the ground under its feet stands on it: when the first
frames saw a surface within `surface_gate_m` of the robot's filtered elevation, the robot's
elevation is that surface's height from the start (`start_surface_m`: the median of all the
waiting frames' views of it, odometry's drift taken out; the surface the feet stood on at the
start lies at the start pose's z).

On exact data (ideal depth, no encoder error) every measurement is 0 and so is the shift.
On a flat floor each frame's ground lies exactly at the feet's height (0), as the paper's
per-frame shift put it.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mapper.validation import check_field

__all__ = [
    "MAX_NECK_OFFSET_M",
    "NECK_FIELDS",
    "HeightReference",
    "HeightReferenceParams",
    "arrival_drift_m",
    "neck_prior_m",
    "start_surface_m",
]


NECK_FIELDS = ("neck_in_camera_x_m", "neck_in_camera_y_m", "neck_in_camera_z_m")
"""Where the neck turns the head, in the camera frame: one field per axis."""

MAX_NECK_OFFSET_M = 1.0
"""How far the neck may lie from the camera [m]: centimetres on a humanoid; a metre bounds a
typo (a neck metres away would predict metres of height error)."""


def neck_prior_m(
    rotation: NDArray[np.float64],
    transform_camera_to_robot: NDArray[np.float64],
    neck_in_camera_m: NDArray[np.float64],
) -> float:
    """The ground measurement a frame's tilt correction predicts [m] (`HeightReference.update`).

    The tilt correction turns the believed data by ``rotation`` about the camera centre. If the
    tilt came from the neck's encoders, the truth is that turn about the neck, which also moves
    the camera by ``(I − R)·(n − c)`` (``n − c`` the neck from the camera, robot frame): the
    ground then lies that much lower in the corrected data than the kinematics say, and a
    frame measures it as a shift of ``((I − R)·(n − c))_z``.

    Args:
        rotation: (3, 3) the applied tilt correction.
        transform_camera_to_robot: (4, 4) the corrected camera pose (``rotation`` applied).
        neck_in_camera_m: (3,) the neck in the camera's optical frame [m].

    Returns:
        The predicted shift [m]; 0 for no rotation or a neck at the camera centre.
    """
    lever = rotation.T @ (transform_camera_to_robot[:3, :3] @ neck_in_camera_m)
    return float((lever - rotation @ lever)[2])


@dataclass(frozen=True)
class HeightReferenceParams:
    """Parameters of the height reference.

    Attributes:
        gate_m: a ground candidate lies within this of the expected shift [m] (0 before the
            estimate converged). 0.02: the encoders' camera height error is −14 to +6 mm on
            the stage (seeds 1-8), a frame's ground scatters by about ±4 mm; walking down, the
            large ground 31 mm below a tread appears at −31 + 6 = −25 mm with the worst positive
            error, which 0.025 let in (stage_down seeds 5 and 7: every row +27 mm). A 31 mm
            tread above the feet can lie inside the gate — `min_area_m2` excludes it.
        min_area_m2: smallest footprint of a ground candidate [m²]. 0.3: above the largest
            tread or threshold of the shipped scenes (0.28 × 1.6 = 0.45 m² is larger, but its
            height, 45 mm, lies outside the gate) and any sill top (0.1 m²); the ground seen
            from the robot covers 3-6 m².
        min_frames: measurements before the estimate has converged. 8: the median of 8
            frames whose heights scatter by ±3-5 mm (one frame's ground on the stage) is good
            to about 1 mm.
        max_wait_frames: frames without convergence after which the kinematics are trusted
            (0: never). 400 (32 s at 12.5 Hz): longer than the walk down the stage's staircase
            before the ground is in view (about 190 frames) and, in stereo, the frames on the
            ground until the estimate is precise (`known_error_m`: known at frame 187-311 on
            stage_down seeds 1, 3, 6, 7, 8); it also bounds the frames a caller defers (about
            0.2 MB each for 88×72 images).
        frame_gate_m: a frame's own measurement within this of the estimate is its shift [m]
            (`HeightReference.frame_shift_m`). 0.005: on the stage (seed 1) a frame's
            measurement lies within 2.6 mm of the estimate in 95 % of the frames (at most
            5.3 mm) — the encoders' noise, which the measurement follows; a ground fragment or
            a surface farther off than that takes the estimate.
        start_gate_m: at the start level, before convergence, a region of at least
            `start_min_area_m2` is a candidate up to this from the prior [m]. 0.04: a neck
            bias of 7° (the paper's bound) puts the camera up to 24 mm off on the stage (seeds
            1-8), plus a frame's ±4 mm scatter.
        start_min_area_m2: smallest footprint of a candidate beyond `gate_m` at the start
            level [m²]. 1.0: the ground seen from the robot covers 3-6 m²; the largest tread
            of the shipped scenes covers 0.45 m² and a patch of a step taken for the ground
            0.31 m².
        start_level_m: the robot is at its start level while odometry's z lies within this of
            the start pose's [m]. 0.01: the lowest step of the shipped scenes is 31 mm, and
            odometry drifts by about 1 mm until the robot steps.
        surface_gate_m: a frame that measured the ground under its feet stands on a surface
            the first frames saw when the robot's filtered elevation lies within this of it
            [m] (`start_surface_m`). 0.01: the filter is at most 3 mm off after a walk
            (stage_down, seeds 1-8); the lowest step of the shipped scenes is 31 mm.
        known_error_m: below the start level, the waiting frames are mapped
            (`HeightReference.known`) once the converged estimate's standard error is at most
            this [m]: the median's,
            1.2533 · σ / √n with σ = 1.4826 · MAD of the measurements at the lowest level.
            0.0005: half the issue's aim of 1 mm per row (the rest is left to odometry's drift
            and the sensor). Stereo measures a frame's ground with a scatter of 4.2-5.7 mm
            (stage_down, seeds 1-8), so the median of `min_frames` = 8 was 0.5-3 mm off the
            camera's true height error (every row of a seed off by as much), and about 130
            measurements reach 0.5 mm; depth scatters by about a millimetre, and 8 suffice.
        start_known_error_m: at the start level the converged estimate is the start
            surface's (the feet stand on it) once its standard error is at most this [m] or
            `start_known_frames` frames measured it; until then the frames wait as they do
            below it, and the ground candidates keep the start's gates around the prior (a
            narrow gate around an unsettled median would keep only the cluster it lies in).
            The standard error is `HeightReference.start_error_m`'s, σ from the interquartile
            range: a MAD is one cluster's spread when the views come in two. Found on
            `scenarios/holdout/down_shallow_steps` in stereo (session 45): on an 85 mm landing
            whose ground is out of view, the first frames took the far ground, misread 57-114
            mm too high (stereo at 3-4 m), for the ground under the feet — 8 measurements from
            -29 to +28 mm on seed 5 — settled on +15.5 mm, and every step was mapped 60-75 mm
            high (seeds 4, 5, 7 and 8: 809-1039 unsafe cells). Their standard errors after 8
            were 3.7-8.7 mm; a stereo start on the ground scatters about as much (the stage,
            seeds 1-8: 1.6-5.4 mm), so this alone cannot tell them apart. 0.003: depth (below
            1 mm) and the quieter stereo starts settle after 8 as before. inf: off (8
            measurements suffice, and the estimate gates from then on).
        start_known_frames: at the start level, this many measurements settle the estimate
            whatever its standard error: the ground under the feet is measured in nearly every
            frame (the stage in stereo: 8 in its first 8-10 frames, `stairs` in its first
            15-21), misreads of a farther surface come and go (the landing's seeds 4, 5, 7, 8:
            10-13 in the whole start, at frames 0-12 and then a few up to frame 93). 16: twice
            `min_frames`, so a noisy stereo start waits 8 frames more, not the 20-30 its
            standard error needs. The waiting frames are mapped without z-matching: in stereo,
            where the robot starts on the ground, step rows came out up to about a millimetre
            further off (`stairs` step_1 2.08 → 3.19 mm; README, "Held-out scenes").
        tread_min_area_m2: walking down before the estimate is known, a frame whose feet
            stand on a *tread* may not take a large region farther than `tread_gate_m` from
            its prior for the ground under them [m²]: a tread is a floor region the waiting
            frames saw at least this large but smaller than the ground around the robot
            (`start_min_area_m2`), at a level (odometry's rise + its height + the frame's
            prior, `neck_prior_m`: the camera's height error moves every region a frame sees)
            within `surface_gate_m` of the feet's (the rise). The large region is then likely
            the surface one rise below the tread. 0.05: a tread seen in part covers 0.1-0.3 m²
            (stereo's fattened edges: a 0.25 m² tread measured 0.31 m², above `min_area_m2`),
            depth noise's patches a few hundredths. Found on a held-out scene (session 44,
            `scenarios/holdout/down_slant_turn`, a 20 mm lowest step): the frames on it
            measured the ground 20 mm below, 19.5 mm from their prior (inside `gate_m`),
            converged there, and every row went 14-20 mm off (depth seeds 7 and 8: 477 and
            6681 unsafe cells; stereo seed 7: 6873). 0 = off.
        tread_gate_m: how far from its prior [m] a frame on a tread (`tread_min_area_m2`) may
            measure the ground. 0.01: on the ground a frame's measurement lies within about
            2 mm of its prior in depth and 6 mm in stereo (`down_slant_turn` seed 7, frames
            145-184, one stereo outlier at 19 mm), so a patch of the ground taken for a tread
            still measures; the ground one 20 mm rise below lies 19.5 mm from it.
        neck_in_camera_x_m: where the neck turns the head, in the camera's optical frame (x
            right, y down, z forward) [m]: x. With the tilt correction it gives the prior
            (`neck_prior_m`): a neck encoder's error turns the camera about the neck, so the
            tilt it causes comes with a height error of the camera, which the tilt correction
            (a rotation about the camera centre, the paper's) leaves to this reference.
        neck_in_camera_y_m: its y [m].
        neck_in_camera_z_m: its z [m]. (0, 0, 0) (default): the prior is 0, the kinematics'
            height. fogsim sets the robot's (`pivot_in_camera_m` of its description's
            ``[neck]``; iCub: 10 cm below the eyes, 9 cm behind). stage_down, depth,
            ``encoders.head_bias_deg = 7`` (camera errors 7-12°, session 42), 0 → iCub's
            neck: seed 2 every row −20.7 mm off → +0.52 … +0.98 mm (the ground, 21 mm off the
            kinematics, was never inside the gate: no estimate, the kinematics' height
            trusted), seed 7 −4.1 → −0.27 … −0.56 mm; every row of the seven walking
            scenarios' seeds 1-8 within 0.36 mm of the same seed at the default 4°. At 4°
            the depth suite is the same in every figure.
    """

    gate_m: float = 0.02
    min_area_m2: float = 0.3
    min_frames: int = 8
    max_wait_frames: int = 400
    frame_gate_m: float = 0.005
    start_gate_m: float = 0.04
    start_min_area_m2: float = 1.0
    start_level_m: float = 0.01
    surface_gate_m: float = 0.01
    known_error_m: float = 0.0005
    start_known_error_m: float = 0.003
    start_known_frames: int = 16
    tread_min_area_m2: float = 0.05
    tread_gate_m: float = 0.01
    neck_in_camera_x_m: float = 0.0
    neck_in_camera_y_m: float = 0.0
    neck_in_camera_z_m: float = 0.0

    @property
    def neck_in_camera_m(self) -> NDArray[np.float64]:
        """(3,) the neck in the camera's optical frame [m]."""
        return np.array([self.neck_in_camera_x_m, self.neck_in_camera_y_m, self.neck_in_camera_z_m])

    def __post_init__(self) -> None:
        for name in (
            "gate_m",
            "min_area_m2",
            "frame_gate_m",
            "start_gate_m",
            "start_min_area_m2",
            "start_level_m",
            "surface_gate_m",
            "known_error_m",
            "tread_gate_m",
        ):
            check_field(
                "HeightReferenceParams",
                name,
                getattr(self, name),
                float,
                "a finite float > 0",
                lambda v: math.isfinite(v) and v > 0,
            )
        for name in NECK_FIELDS:
            check_field(
                "HeightReferenceParams",
                name,
                getattr(self, name),
                float,
                f"a finite float within ±{MAX_NECK_OFFSET_M:g} [m] of the camera",
                lambda v: math.isfinite(v) and abs(v) <= MAX_NECK_OFFSET_M,
            )
        check_field(
            "HeightReferenceParams",
            "start_known_error_m",
            self.start_known_error_m,
            float,
            "a float > 0 [m] (inf: off)",
            lambda v: v > 0,
        )
        check_field(
            "HeightReferenceParams",
            "start_known_frames",
            self.start_known_frames,
            int,
            "an integer >= 1",
            lambda v: v >= 1,
        )
        check_field(
            "HeightReferenceParams",
            "tread_min_area_m2",
            self.tread_min_area_m2,
            float,
            f"0 (off) or a finite float in (0, start_min_area_m2 ({self.start_min_area_m2})) [m²]",
            lambda v: math.isfinite(v) and 0.0 <= v < self.start_min_area_m2,
        )
        check_field(
            "HeightReferenceParams",
            "min_frames",
            self.min_frames,
            int,
            "an integer >= 1",
            lambda v: v >= 1,
        )
        check_field(
            "HeightReferenceParams",
            "max_wait_frames",
            self.max_wait_frames,
            int,
            "an integer >= 0",
            lambda v: v >= 0,
        )


class HeightReference:
    """The z shift of the camera height, estimated over frames (see the module docstring).

    Attributes:
        measurements_m: every frame's measured shift so far [m], in frame order.
        rises_m: odometry's rise (z minus the start pose's) at each measurement [m].
        frames: frames seen.
    """

    def __init__(self, params: HeightReferenceParams | None = None) -> None:
        self.params = params if params is not None else HeightReferenceParams()
        self.measurements_m: list[float] = []
        self.rises_m: list[float] = []
        self.frames = 0
        # Kept by `update`: the lowest rise (min(rises_m), NaN once one is NaN), the
        # measurements at the lowest level in increasing order and their median (read 2-3
        # times a frame); a measurement of zero (either sign) at that level makes every median
        # numpy's (which of 0.0 and -0.0 is the middle one is the sort's choice).
        self._lowest_rise_m = math.inf
        self._lowest_sorted_m: list[float] = []
        self._shift_m = 0.0
        self._zero_at_lowest = False
        self._settled = False  # converged once, and precise unless at the start level
        # Levels (odometry's rise + the prior + the region's height) [m] of the treads the
        # frames saw until the estimate was known (`_on_tread`).
        self._tread_levels_m: list[float] = []

    @property
    def converged(self) -> bool:
        """`min_frames` measurements at the lowest level: the estimate is trusted."""
        return len(self._lowest_sorted_m) >= self.params.min_frames

    @property
    def known(self) -> bool:
        """A frame's data may be mapped: converged, or waited `max_wait_frames` in vain.

        The first time only, converged also means precise: below the start level (the robot
        walked down before its ground came into view) the standard error within
        `known_error_m`, at it `start_known_error_m` or `start_known_frames`. Later, one more
        frame's scatter can put the standard error above it again, and waiting for one frame
        anew would anchor the frames after it to that frame's view of the ground alone
        (stereo, stage_down seed 6: every row −7 mm).
        """
        wait = self.params.max_wait_frames
        return (self.converged and self._settled) or (wait > 0 and self.frames >= wait)

    @property
    def error_m(self) -> float:
        """The estimate's standard error [m] (inf before `min_frames` measurements).

        Computed when asked: O(n) in the measurements at the lowest level.
        """
        return self._median_error_m()

    @property
    def start_error_m(self) -> float:
        """The start level's standard error of the estimate [m] (inf before `min_frames`).

        As `error_m` with σ from the interquartile range (``IQR / 1.349``) instead of the
        MAD: measurements in two clusters (a stereo start's views at +15 and -15 mm, 5 and 4
        of them) have a MAD of one cluster's spread, 3 mm, which would settle the estimate on
        that cluster; their IQR spans both.
        """
        return self._median_error_m(interquartile=True)

    @property
    def shift_m(self) -> float:
        """The z shift to add to every frame's data [m]: median at the lowest level, 0 without."""
        return self._shift_m

    def frame_shift_m(self, measured_m: float | None) -> float:
        """The shift of one frame [m]: its own measurement if it agrees with the estimate.

        A frame whose ground measurement lies within `frame_gate_m` of the estimate saw the
        ground the estimate was made of: shifted by its own measurement, that ground lies
        exactly at the feet's height, as the kinematics of the start pose say (the camera's
        height error changes from frame to frame with the encoders' noise, which one shift for
        the run cannot follow). Any other frame takes the estimate.

        Args:
            measured_m: the frame's measurement (`update`'s result; None: none).
        """
        return measured_m if self.agrees(measured_m) else self.shift_m

    def agrees(self, measured_m: float | None) -> bool:
        """A frame's measurement lies within `frame_gate_m` of the estimate (None: no)."""
        return measured_m is not None and abs(measured_m - self.shift_m) <= self.params.frame_gate_m

    def ground_sized_m(
        self,
        heights_m: NDArray[np.float64],
        areas_m2: NDArray[np.float64],
        is_floor: NDArray[np.bool_],
    ) -> NDArray[np.float64]:
        """Heights of the floor regions large enough to be the ground around the robot [m].

        No gate: what a waiting frame saw at any height (`arrival_drift_m`'s start surfaces).
        Largest first (ties in region order): depth noise splits the ground into fragments
        millimetres apart, and the largest is the ground's most precise height.

        Args:
            heights_m: (F,) region heights in the tilt-corrected robot frame, unshifted [m].
            areas_m2: (F,) their footprints [m²].
            is_floor: (F,) the region is a floor.
        """
        keep = np.flatnonzero(is_floor & (areas_m2 >= self.params.min_area_m2))
        return np.asarray(heights_m[keep[np.argsort(-areas_m2[keep], kind="stable")]])

    def update(
        self,
        heights_m: NDArray[np.float64],
        areas_m2: NDArray[np.float64],
        is_floor: NDArray[np.bool_],
        rise_m: float,
        prior_m: float = 0.0,
    ) -> float | None:
        """Take one frame's floor regions; return its measured shift [m] (None: no ground).

        Args:
            heights_m: (F,) region heights in the tilt-corrected robot frame, unshifted [m].
            areas_m2: (F,) their footprints [m²].
            is_floor: (F,) the region is a floor.
            rise_m: odometry's z minus the start pose's [m] (the robot's change of level).
            prior_m: the shift the frame's pose predicts [m], where the gates centre until the
                estimate has converged (`neck_prior_m`; 0: the kinematics' height).
        """
        self.frames += 1
        params = self.params
        on_tread = False
        if params.tread_min_area_m2 > 0.0 and not self.known and math.isfinite(rise_m):
            on_tread = self._on_tread(rise_m)
            self._add_treads(heights_m, areas_m2, is_floor, rise_m + prior_m)
        # At the start level an estimate gates only once settled: a narrow gate around an
        # unsettled median keeps the cluster it lies in and drops the other (a stereo start's
        # views two clusters at +-15 mm: settled on +13 mm instead of 0).
        trusted = self.converged and (self._settled or not self._at_start_level())
        expected = self.shift_m if trusted else prior_m
        offset = np.abs(-heights_m - expected)
        candidate = is_floor & (areas_m2 >= params.min_area_m2) & (offset <= params.gate_m)
        if not trusted and abs(rise_m) <= params.start_level_m:
            candidate |= (
                is_floor & (areas_m2 >= params.start_min_area_m2) & (offset <= params.start_gate_m)
            )
        if not candidate.any():
            return None
        largest = int(np.argmax(np.where(candidate, areas_m2, -np.inf)))
        measured = -float(heights_m[largest])
        if on_tread and abs(measured - prior_m) > params.tread_gate_m:
            return None  # the surface one rise below the tread (`tread_min_area_m2`)
        self.measurements_m.append(measured)
        self.rises_m.append(rise_m)
        # The median of the measurements at the lowest level (odometry's rise within
        # `start_level_m` of its lowest): kept in order as they come, it costs O(log frames) a
        # frame; the whole history is gone through again only for a new lowest level. The same
        # numbers as `np.median` over the history every frame (tests/test_exact_fast_paths.py):
        # a measurement is finite (within `gate_m` of the estimate).
        lowest_m = self._lowest_rise_m
        if rise_m > lowest_m + params.start_level_m:  # above that level: nothing changes
            return measured
        if lowest_m <= rise_m and not (self._zero_at_lowest or measured == 0.0):
            bisect.insort(self._lowest_sorted_m, measured)  # at that level, which stays
            self._shift_m = _sorted_median(self._lowest_sorted_m)
            self._settle()
            return measured
        rises = np.asarray(self.rises_m)  # a new lowest level (or a NaN rise): all over
        self._lowest_rise_m = float(rises.min())
        lowest = np.asarray(self.measurements_m)[
            rises <= self._lowest_rise_m + params.start_level_m
        ]
        self._lowest_sorted_m = sorted(lowest.tolist())
        self._zero_at_lowest = bool(np.any(lowest == 0.0))
        self._shift_m = float(np.median(lowest))
        self._settle()
        return measured

    def _add_treads(self, heights_m, areas_m2, is_floor, base_m: float) -> None:
        """Keep the levels of the frame's treads (`tread_min_area_m2`).

        ``base_m``: the frame's rise plus its prior (the camera height error its pose
        predicts, which moves every region it sees).
        """
        p = self.params
        levels = base_m + np.asarray(heights_m, dtype=np.float64)
        areas = np.asarray(areas_m2, dtype=np.float64)
        tread = (areas >= p.tread_min_area_m2) & (areas < p.start_min_area_m2)
        tread &= np.asarray(is_floor, dtype=bool) & np.isfinite(levels)
        self._tread_levels_m.extend(levels[tread].tolist())

    def _on_tread(self, rise_m: float) -> bool:
        """Below the start level, the feet stand on a tread the frames saw.

        One within `surface_gate_m` of the feet's level ``rise_m`` (`tread_min_area_m2`).
        """
        if abs(rise_m) <= self.params.start_level_m or not self._tread_levels_m:
            return False
        treads = np.asarray(self._tread_levels_m)
        return bool(np.any(np.abs(treads - rise_m) <= self.params.surface_gate_m))

    def _settle(self) -> None:
        """The estimate's standard error; settled once converged and precise enough.

        At the start level the ground under the feet is the start surface, at the start pose's
        z by the kinematics, and the map is anchored there (`start_surface_m`): a standard
        error within `start_known_error_m` (`start_error_m`) or `start_known_frames`
        measurements suffice (waiting for more put stereo's map on the stage 0.5 mm further
        off, ground 0.35 → 0.82 mm mean). Below it, the map is anchored to the waiting frames'
        view of the ground, shifted by this estimate: its error is the map's offset, which
        `known_error_m` bounds.
        """
        if self._settled or not self.converged:  # latched; the median's error costs O(n)
            return
        if self._at_start_level():
            self._settled = (
                len(self._lowest_sorted_m) >= self.params.start_known_frames
                or self.start_error_m <= self.params.start_known_error_m
            )
        else:
            self._settled = self._median_error_m() <= self.params.known_error_m

    def _at_start_level(self) -> bool:
        """The lowest level measured at is the start's (within `start_level_m`; NaN: not)."""
        return abs(self._lowest_rise_m) <= self.params.start_level_m

    def _median_error_m(self, interquartile: bool = False) -> float:
        """Standard error of the median at the lowest level [m] (inf below `min_frames`).

        1.2533 · σ / √n, σ = 1.4826 · MAD: robust to the frames that took a wrong surface;
        with ``interquartile``, σ = IQR / 1.349 (`start_error_m`).
        """
        values = np.asarray(self._lowest_sorted_m)
        if values.size < self.params.min_frames:
            return math.inf
        if interquartile:
            q25, q75 = np.percentile(values, [25.0, 75.0])
            sigma_m = float(q75 - q25) / 1.349
        else:
            sigma_m = 1.4826 * float(np.median(np.abs(values - self._shift_m)))
        return 1.2533 * sigma_m / math.sqrt(values.size)


def _sorted_median(values: list[float]) -> float:
    """`np.median` of finite values in increasing order: the middle one, or the mean of two."""
    half = len(values) // 2
    if len(values) % 2:
        return values[half]
    return (values[half - 1] + values[half]) / 2.0


def _largest_per_frame(
    start_surfaces_m: list[NDArray[np.float64]], z_m: float, gate_m: float
) -> list[tuple[int, float]]:
    """(frame, height) of each frame's largest surface within ``gate_m`` of ``z_m``, in order.

    The surfaces of a frame are listed largest first (`HeightReference.ground_sized_m`); frames
    without one are left out. The largest, not the nearest: a frame whose ground is split into
    fragments a millimetre apart would otherwise give the fragment nearest the robot's
    elevation, which then stays (room, seed 3: the ground 0.8 mm low from frame 145 on).
    """
    found: list[tuple[int, float]] = []
    for index, surfaces in enumerate(start_surfaces_m):
        within = np.flatnonzero(np.abs(surfaces - z_m) <= gate_m)
        if within.size:
            found.append((index, float(surfaces[within[0]])))
    return found


def arrival_drift_m(
    start_surfaces_m: list[NDArray[np.float64]],
    fractions: NDArray[np.float64],
    arrival_z_m: float,
    start_z_m: float,
    params: HeightReferenceParams,
) -> float | None:
    """Odometry's z drift on arriving on a surface the first frames saw [m] (None: not seen).

    When the height reference converges, the robot stands on the ground it measured, which
    odometry puts at ``arrival_z_m``. Still at its start level (within `start_level_m` of
    ``start_z_m``, the start pose's z), that ground is the surface the feet stood on at the
    start, at ``start_z_m`` by the kinematics: the drift is ``arrival_z_m − start_z_m``,
    exactly. (The waiting frames' views of it would add their noise: stereo, seed 6, ±20 mm a
    frame, and a drift of −3 mm made of it while odometry was exact.)

    Arriving on another surface (walking down), the waiting frames saw it at world heights
    ``start_surfaces_m`` (odometry's z + region height + the frame's shift, largest first). The
    drift grows in proportion to the way walked (foot-to-foot kinematics add a like error at
    every step), so frame ``f`` of the way saw the surface at ``G + e + f·D``: ``G`` its height,
    ``e`` the waiting frames' camera height error, which none of them could measure (the
    surface under their feet out of view: stage_down, seed 3, 1-1.5 mm) and ``D`` the drift.
    ``D`` is the slope of the heights over the way (Theil–Sen: the median of the pairwise
    slopes, robust to a frame's wrong surface), whatever ``e`` is. Of each frame the largest
    surface within `gate_m` of ``arrival_z_m`` is taken, at least `min_frames` frames are
    needed. (Taking ``e`` as 0 and each frame's ``(arrival_z_m − height) / (1 − f)`` put the
    drift 1.5 mm short on stage_down seed 3: the waiting frames' camera error.)

    Args:
        start_surfaces_m: per waiting frame in order, the world heights of its ground-sized
            floor regions, largest first [m].
        fractions: (W,) each waiting frame's place between the start (0) and the arrival (1).
        arrival_z_m: odometry's z of the robot when the reference converged [m].
        start_z_m: odometry's z of the start pose (exact) [m].
        params: the reference's parameters (`gate_m`, `min_frames`, `start_level_m`).
    """
    if abs(arrival_z_m - start_z_m) <= params.start_level_m:
        return arrival_z_m - start_z_m
    found = _largest_per_frame(start_surfaces_m, arrival_z_m, params.gate_m)
    if len(found) < params.min_frames:
        return None
    ways = np.array([float(fractions[i]) for i, _ in found])
    heights = np.array([height for _, height in found])
    first, second = np.triu_indices(ways.size, k=1)
    return float(np.median((heights[second] - heights[first]) / (ways[second] - ways[first])))


def start_surface_m(
    start_surfaces_m: list[NDArray[np.float64]],
    z_m: float,
    start_z_m: float,
    params: HeightReferenceParams,
) -> float | None:
    """Height of the surface the first frames saw within `surface_gate_m` of ``z_m`` [m].

    The surface the feet stood on at the start lies at the start pose's z ``start_z_m`` (the
    kinematics): within the gate of it, that is the surface, exactly. (The first frames' views
    of it scatter: stereo, ±20 mm a frame, so the view nearest a drifting elevation locked the
    robot 14 mm low for the rest of the run, seed 6.) Any other: the median, over all the first
    frames that saw one, of each frame's largest surface within the gate (None: no frame saw
    one). All, not the earliest `min_frames`: odometry's drift is taken out of them, and the
    earliest 8 frames' median was 1.4 mm off on stage_down seed 3 (the ground row −1.5 mm).

    Args:
        start_surfaces_m: per first frame in order, the world heights of its ground-sized
            floor regions, largest first, odometry's drift taken out [m].
        z_m: the robot's filtered elevation [m].
        start_z_m: odometry's z of the start pose (exact) [m].
        params: the reference's parameters (`surface_gate_m`).
    """
    if abs(z_m - start_z_m) <= params.surface_gate_m:
        return start_z_m
    found = _largest_per_frame(start_surfaces_m, z_m, params.surface_gate_m)
    if not found:
        return None
    return float(np.median(np.asarray([height for _, height in found])))
