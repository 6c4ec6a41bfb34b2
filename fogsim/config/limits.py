"""The configuration layer's limits: what a scenario may ask for without exhausting the machine.

Each limit is far above every shipped scenario (largest: ``stage``, 3 KB, 9 objects, 88 × 72
px at 12.5 Hz) and below what breaks or stalls a run; the docstrings say why the number. The
schema (:mod:`fogsim.config.schema`) declares its fields with them; the loader
(:mod:`fogsim.config.load`) bounds what it reads.
"""

from __future__ import annotations

import re

SCENARIO_NAME_PATTERN = r"(?!.*\.\.)[A-Za-z0-9][A-Za-z0-9_.-]{0,63}"
"""A scenario's ``name`` (the whole of it must match): 1–64 letters, digits, ``_``, ``.`` or ``-``,
starting with a letter or digit, no ``..``. The name becomes a folder or file name (``runs/<name>``,
the suite's ``OUT/<name>/``, tune's recording cache), so it must be one safe path component: no
separator, not absolute, not ``.`` or ``..``, no leading ``-`` (read as an option) or ``.``
(hidden), 64 characters at most (every file system allows 255 bytes per component)."""
SCENARIO_NAME = re.compile(SCENARIO_NAME_PATTERN)
""":data:`SCENARIO_NAME_PATTERN` compiled (use ``fullmatch``)."""

MAX_SCENARIO_FILE_BYTES = 1 << 20
"""Largest scenario file read [bytes] (1 MiB): 350 × the largest shipped one (``stage``, 3 KB);
it holds every object, event and route step the other limits allow many times over, while a
larger file (a log pasted by mistake, a device) is refused before it is read into memory."""

MAX_FRAME_RATE_HZ = 100.0
"""Highest camera frame rate [Hz]: 8 × the paper's 12.5 Hz and above every depth camera's rate
at its full resolution. The gait's fastest motion (a 0.525 s swing) gets 50 samples at this rate;
more frames add cost (the whole trajectory is planned, every frame rendered and mapped), not
detail."""

MAX_OBJECTS = 256
"""Most ``[[objects]]`` of a scenario. Each object is a MuJoCo body, geom and material;
MuJoCo's renderer stops with a fatal error above 1000 materials (the robot brings its own), and
every frame's ground truth tests every object. ``stage`` has 9."""

MAX_EVENTS = 256
"""Most ``[[events]]`` of a scenario: every frame places every object from its events, so the
cost of a frame grows with objects × events. One event per object (:data:`MAX_OBJECTS`) fits."""

WORLD_BOUND_M = 1000.0
"""Largest |x| or |y| of a position in the world [m] (object centres, route targets, the start,
event destinations): a kilometre, far beyond the 24 × 24 m floor, and small enough that a
float32 (OpenGL) position still resolves 0.1 mm."""

MAX_OBJECT_EXTENT_M = 100.0
"""Largest side of an object [m]: four times the floor's side."""

MIN_CAMERA_SIDE_PX = 8
"""Smallest camera width or height [px]: an 8 × 8 image runs in the ``ideal`` and ``depth`` modes
(no filter or block needs more); see :data:`MIN_STEREO_WIDTH_PX` for the ``stereo`` mode."""

MIN_STEREO_WIDTH_PX = 18
"""Smallest camera width [px] in the ``stereo`` mode: its matcher (``fogsim.sim.camera.stereo``)
renders at twice the width and searches 32 px of disparity with a 5 px block; OpenCV's SGBM needs
render width - 32 > 5 // 2, so 2 × 18 = 36 px is the least (narrower images crash OpenCV)."""

MAX_CAMERA_SIDE_PX = 2048
"""Largest camera width or height [px]: Full HD (1920 × 1080) fits. The stereo mode renders at
twice that, 4096 px, within OpenGL's renderbuffer limit (llvmpipe and desktop GPUs: ≥ 8192; the
scene sizes its off-screen buffer to it). Measured on the 2-core test machine: a 2048 × 2048
``ideal`` run peaks at 1.5 GB and maps a frame in 0.3 s; 4096 × 4096 would need about four times
that per frame."""
