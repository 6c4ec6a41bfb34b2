"""Layer 3 — data: the per-frame contract (:class:`Frame`) and recordings of frames.

* :mod:`fogsim.data.frame` — :class:`Frame`, what the testbed hands the mapper each frame;
* :mod:`fogsim.data.recording` — :class:`Recording`, :func:`save_recording`,
  :func:`load_recording`: a run's frames in one versioned ``.npz`` file.
"""

from fogsim.data.frame import Frame
from fogsim.data.recording import Recording, load_recording, save_recording

__all__ = ["Frame", "Recording", "load_recording", "save_recording"]
