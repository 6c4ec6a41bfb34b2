"""The walking planner's limits: how long a planned walk may be and how close the legs must come."""

MAX_TRAJECTORY_FRAMES = 20_000
"""Most frames of a planned walk (the settle stands included). At the paper's 12.5 Hz that is
26.7 minutes of walking, 24 × the ``stage`` route (66.5 s, 832 frames). The whole walk is
planned before the first frame (measured: 4.8 s for a 19 701-frame walk of iCub; the
configurations take frames × nq × 8 bytes, 6.2 MB for nq = 39), then every frame is rendered and
mapped; a one-hour wait at 100 Hz (360 001 frames) is refused before it is planned."""

MAX_IK_RESIDUAL_M = 1e-3
"""A walk whose leg IK misses a footstep by more than this [m] is refused: the converged IK
reaches its footsteps to 1 µm (``GaitParams.ik_tolerance_m``), a miss of a millimetre means
the leg cannot reach."""
