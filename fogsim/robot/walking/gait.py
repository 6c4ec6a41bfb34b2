"""Parameters of the kinematic gait (footstep sizes, timing, swing, sway, leg IK)."""

from dataclasses import dataclass

from fogsim.errors import RouteError


@dataclass(frozen=True)
class GaitParams:
    """Parameters of the kinematic gait (the defaults suit iCub).

    Attributes:
        step_length_m: Nominal advance of a foot ahead of the other [m].
        max_step_m: Longest allowed advance of a foot ahead of the other [m].
        min_progress_m: Smallest advance of a swing foot over its previous position [m].
        step_period_s: Duration of one step (double support + swing) [s].
        double_support_fraction: Fraction of the step period with both feet down.
        swing_clearance_m: Sole clearance above the highest surface under the swing path [m].
        turn_step_deg: Largest yaw change per pair of steps when turning in place [deg].
        heading_tolerance_deg: ``walk_to`` turns in place first if the heading differs more.
        flat_tolerance_m: Footprint height spread that still counts as one surface [m].
        footprint_margin_m: Margin added around the sole when checking flatness [m].
        sway_m: Lateral pelvis sway towards the stance foot [m].
        bob_m: Vertical pelvis bob during swing [m].
        leg_reach_margin_m: The pelvis stays this much below full leg extension [m].
        look_default_deg: Head (yaw, pitch) before any ``look`` command [deg].
        look_transition_s: Time a ``look`` command takes (the robot stands) [s].
        ik_tolerance_m: Leg IK residual (position) to reach [m].
        ik_max_iterations: CLIK iterations per leg and frame.
    """

    step_length_m: float = 0.09
    max_step_m: float = 0.3
    min_progress_m: float = 0.03
    step_period_s: float = 0.7
    double_support_fraction: float = 0.25
    swing_clearance_m: float = 0.03
    turn_step_deg: float = 15.0
    heading_tolerance_deg: float = 3.0
    flat_tolerance_m: float = 0.002
    footprint_margin_m: float = 0.005
    sway_m: float = 0.02
    bob_m: float = 0.006
    leg_reach_margin_m: float = 0.012
    look_default_deg: tuple[float, float] = (0.0, -30.0)
    look_transition_s: float = 0.5
    ik_tolerance_m: float = 1e-6
    ik_max_iterations: int = 50

    def __post_init__(self) -> None:
        checks = {
            "step_length_m": 0.0 < self.step_length_m <= self.max_step_m,
            "min_progress_m": 0.0 < self.min_progress_m <= self.step_length_m,
            "step_period_s": self.step_period_s > 0.0,
            "double_support_fraction": 0.0 <= self.double_support_fraction < 1.0,
            "swing_clearance_m": self.swing_clearance_m > 0.0,
            "turn_step_deg": 0.0 < self.turn_step_deg <= 45.0,
            "look_transition_s": self.look_transition_s > 0.0,
            "ik_tolerance_m": self.ik_tolerance_m > 0.0,
        }
        for name, ok in checks.items():
            if not ok:
                raise RouteError(f"GaitParams.{name}={getattr(self, name)!r} is out of range")
