"""Exceptions raised by the testbed: one tree under :class:`FogsimError`.

Every message names what was wrong (file, key path or argument, the value) and what is
allowed. Errors about a value a caller passed are also :class:`ValueError`, so generic code
that catches ``ValueError`` keeps working. The command line catches :class:`FogsimError` (and
the mapper's :class:`mapper.errors.MapperError`) and exits with code 2.
"""


class FogsimError(Exception):
    """Base class of every error the testbed raises."""


class ScenarioError(FogsimError, ValueError):
    """A scenario file is invalid; the message names the file, the key and what is allowed."""


class ParameterError(FogsimError, ValueError):
    """A mapper, segmentation, pipeline or tuning parameter is unknown or out of range."""


class RobotModelError(FogsimError):
    """A robot model cannot be loaded or lacks a frame the testbed needs."""


class RouteError(FogsimError, ValueError):
    """A route step is malformed or the terrain leaves no place to put a foot."""


class EncoderError(FogsimError, ValueError):
    """Invalid encoder parameters or readings."""


class CameraError(FogsimError, ValueError):
    """A camera configuration the renderer or the matcher cannot serve."""


class OutputError(FogsimError):
    """An output path cannot be written.

    A file where a folder is needed, a read-only or full disk, a kernel pseudo-filesystem, a
    folder holding files of something else, or a path from data that leaves its folder. The
    message names the argument or path, the problem and what is allowed.
    """


class RecordingError(FogsimError, ValueError):
    """A recording file is missing, corrupt or of an unsupported version."""


class FrameError(FogsimError, ValueError):
    """A frame's believed pose cannot be mapped; the message names the frame and the value."""


class ArchiveExtentError(FogsimError, ValueError):
    """Storing a grid would make the world archive span more than ``MAX_ARCHIVE_CELLS`` cells."""


class ReportError(FogsimError, ValueError):
    """A ``report.json``, ``frames.csv`` or summary file is missing, corrupt or unsupported."""


class TargetsError(FogsimError, ValueError):
    """A targets file (``fogsim suite --targets``) is missing, not TOML or breaks its schema."""


class TuneError(FogsimError, ValueError):
    """A tuning study cannot run: bad ranges, weights, suite or a study that does not match."""


class KernelBundleError(FogsimError):
    """The kernels' shipped build cannot be read or installed.

    A corrupt or truncated bundle, or a numba cache folder that cannot be written. The
    message names the file and the reason; the warm-up then compiles the kernels instead.
    """
