"""The data layer's limits: what a recording and a frame may hold, each number justified.

A recording is checked against these before any of its arrays is read (the sizes its zip
directory and ``.npy`` headers declare) and its poses before a frame is mapped, so a corrupt or
hostile file ends in a :class:`~fogsim.errors.RecordingError` instead of exhausting the machine.
The pipeline (:mod:`fogsim.mapping.pipeline`) holds every frame to the pose limits too.
"""

from __future__ import annotations

MAX_FRAMES = 100_000
"""Frames in one recording: 2.2 hours at the testbed's 12.5 Hz, far beyond any run (the longest
shipped scenario takes under 1000 frames). Bounds every per-frame array of a file."""

MAX_IMAGE_SIDE_PX = 1280
"""Width or height of a depth image [px]: the widest mode of common depth cameras (RealSense
D4xx: 1280 × 720)."""

MAX_IMAGE_PIXELS = 1280 * 960
"""Pixels of a depth image: 1280 × 960, so a frame's depth is at most 4.9 MB as float32 (also
Azure Kinect's 1024 × 1024 wide mode fits). A replay holds one frame's depth at a time."""

MAX_PICKLED_DEPTH_BYTES = 4 << 30
"""Bytes of depth a recording may take along when it is sent to another process (pickled: tune's
Ray workers get the frames, not the file): 4 GiB, e.g. 870 frames of 1280 × 960. Longer
recordings are replayed in one process, or cut (``tune --quick``)."""

MIN_FOCAL_PX = 1.0
"""Smallest focal length [px]: a field of view of 179.9° across a 1280 px image; below it the
back-projected points leave every grid."""

MAX_FOCAL_PX = 1e5
"""Largest focal length [px]: a field of view of 0.7° across 1280 px; no depth camera is that
narrow."""

META_JSON_FIXED_CHARS = 1 << 20
"""Characters of ``meta_json`` besides the ground truth: the intrinsics and the scenario file's
text (shipped scenario files are under 10 000 characters)."""

META_JSON_CHARS_PER_FRAME = 1 << 16
"""Characters of ground truth ``meta_json`` may hold per frame: a frame adds at most one distinct
world state, whose JSON takes about 250 characters per object, so 64 Ki characters hold a world
of 250 objects changing at every frame. ``meta_json`` may hold at most
``META_JSON_FIXED_CHARS + frames * META_JSON_CHARS_PER_FRAME`` characters."""

MAX_POSITION_M = 1e4
"""Largest |x|, |y| or |z| of a pose or camera position in the world [m]: 10 km, beyond any
building or site a robot maps, where float64 still resolves 2 nm and the mapper's cell indices
stay small integers. A 1e30 pose from a broken odometry is refused."""

MAX_ABS_YAW_RAD = 1e4
"""Largest |yaw| of a pose [rad]: odometry may unwrap its yaw over 1600 turns; beyond that the
float64 angle loses its precision (a 1e30 yaw names no direction)."""

MAX_POSE_STEP_M = 5.0
"""Largest distance [m] the believed robot position (x, y, z) may move from one frame to the
next. A humanoid walks below 1.5 m/s, 0.12 m a frame at the testbed's 12.5 Hz; 5 m still allows
gaps of several seconds between frames. A larger step is an odometry failure or corrupt data:
mapping it would place the grid far from everything mapped so far (a 3000 m jump once made the
scoring archive ask for 42 GiB)."""

MAX_CAMERA_OFFSET_M = 10.0
"""Largest distance [m] of the camera from the robot frame's origin: robots are at most a few
metres tall."""

RIGID_TOLERANCE = 1e-6
"""Largest deviation of a rotation block R from orthonormal (|R Rᵀ − I|, entrywise), the same
tolerance as the mapper's segmentation; float64 forward kinematics stay below 1e-14."""

LAST_ROW_TOLERANCE = 1e-12
"""Largest deviation of a 4×4 transform's last row from (0, 0, 0, 1), as the segmentation's."""
