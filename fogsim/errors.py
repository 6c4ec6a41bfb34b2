"""Exceptions raised by the testbed: one hierarchy, messages list the valid choices."""


class FogsimError(Exception):
    """Base class of every error the testbed raises."""


class ScenarioError(FogsimError, ValueError):
    """A scenario file is invalid; the message names the file, the key and what is allowed."""


class RobotModelError(FogsimError):
    """A robot model cannot be loaded or lacks a frame the testbed needs."""


class RecordingError(FogsimError, ValueError):
    """A recording file is missing, corrupt or of an unsupported version."""
