"""Layer 3 — data: the per-frame contract (:class:`Frame`) and recordings of frames.

* :mod:`fogsim.data.frame` — :class:`Frame`, what the testbed hands the mapper each frame;
* :mod:`fogsim.data.limits` — what a recording and a frame may hold, each number justified;
* :mod:`fogsim.data.checks` — poses and transforms against those limits (first bad frame);
* :mod:`fogsim.data.npz` — bounded ``.npz`` reading: headers checked before any data;
* :mod:`fogsim.data.meta` — the ``meta_json`` schema (msgspec structs);
* :mod:`fogsim.data.frames` — :class:`RecordedFrames`, a file's frames built one at a time;
* :mod:`fogsim.data.recording` — :class:`Recording`, :func:`save_recording`,
  :func:`load_recording`: a run's frames in one versioned ``.npz`` file.
"""

from fogsim.data.frame import Frame
from fogsim.data.frames import RecordedFrames
from fogsim.data.recording import Recording, load_recording, save_recording

__all__ = ["Frame", "RecordedFrames", "Recording", "load_recording", "save_recording"]
