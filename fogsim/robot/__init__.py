"""Layer 4 — the robot: its description, kinematics, walking, encoders, odometry and self-filter."""
