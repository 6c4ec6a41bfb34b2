"""MJCF pieces and procedural textures shipped as data (``assets/mjcf/``).

A piece is a small MJCF file holding one part of the scene: render and depth-buffer settings
(``visual``), lights (``lighting``), textures and materials (``materials``), the ground
(``floor``) and the free camera rig (``camera_rig``). Each file says what it holds and why.
A scene merges pieces into its root with ``root.include_copy(load_mjcf_piece(name))``: the
elements keep their names (no ``piece/`` prefix, no attachment frame), in file order.

The textures the materials use are generated, not stored: ``assets/mjcf/textures.toml`` gives
each one's size, grey level, contrast and seed, :func:`scene_textures` turns them into PNG
images (1/f noise, seeded: the same bytes everywhere).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np
from numpy.typing import NDArray

from fogsim.errors import FogsimError
from fogsim.paths import ASSETS_DIR

if TYPE_CHECKING:  # dm_control builds scenes only: a cached compiled scene does without it
    from dm_control import mjcf

MJCF_DIR = ASSETS_DIR / "mjcf"
"""Folder of the MJCF pieces."""
TEXTURES_FILE = MJCF_DIR / "textures.toml"
"""The procedural textures: one table per texture, keys of :class:`NoiseTexture`."""


def load_mjcf_piece(name: str) -> mjcf.RootElement:
    """The piece ``name`` (file ``assets/mjcf/<name>.xml``) as a dm_control MJCF model.

    References to elements of other pieces (the floor's material, say) are left unresolved:
    they resolve when the piece is merged into a scene that holds them.

    Raises:
        FogsimError: There is no such piece (the message lists the pieces there are).
    """
    path = MJCF_DIR / f"{name}.xml"
    if not path.is_file():
        pieces = ", ".join(sorted(p.stem for p in MJCF_DIR.glob("*.xml"))) or "none"
        raise FogsimError(f"no MJCF piece {name!r} ({path} is missing); pieces: {pieces}")
    from dm_control import mjcf  # only to build a scene (TYPE_CHECKING import)

    return mjcf.from_path(str(path), resolve_references=False)


@dataclass(frozen=True)
class NoiseTexture:
    """A square grey texture of 1/f noise (the amplitude spectrum of natural surfaces).

    Attributes:
        size_px: Side of the image [px]; the noise is periodic, so the texture tiles seamlessly.
        mean: Mean grey level in (0, 1).
        rms_contrast: Standard deviation / mean of the grey levels before clipping to [0, 1].
        seed: Seed of the noise.

    Raises:
        FogsimError: A value is out of range (the message names it and what is allowed).
    """

    size_px: int
    mean: float
    rms_contrast: float
    seed: int

    def __post_init__(self) -> None:
        if not 8 <= self.size_px <= 4096:
            raise FogsimError(f"texture size_px must be in [8, 4096], got {self.size_px}")
        if not 0.0 < self.mean < 1.0:
            raise FogsimError(f"texture mean must be in (0, 1), got {self.mean}")
        if not 0.0 <= self.rms_contrast <= 1.0:
            raise FogsimError(f"texture rms_contrast must be in [0, 1], got {self.rms_contrast}")

    def grey(self) -> NDArray[np.float64]:
        """(size, size) grey levels in [0, 1]: white noise filtered to a 1/f amplitude spectrum."""
        rng = np.random.default_rng(self.seed)
        white = rng.standard_normal((self.size_px, self.size_px))
        frequency = np.fft.fftfreq(self.size_px)
        radial = np.hypot(frequency[:, None], frequency[None, :])
        radial[0, 0] = np.inf  # no mean component: the mean is set below
        field = np.fft.ifft2(np.fft.fft2(white) / radial).real
        field = (field - field.mean()) / field.std()
        return np.clip(self.mean * (1.0 + self.rms_contrast * field), 0.0, 1.0)

    def png(self) -> bytes:
        """The texture as an 8-bit RGB PNG image."""
        grey = np.round(255.0 * self.grey()).astype(np.uint8)
        ok, encoded = cv2.imencode(".png", np.repeat(grey[:, :, None], 3, axis=2))
        if not ok:
            raise FogsimError("OpenCV could not encode a texture as PNG")
        return encoded.tobytes()


def scene_textures() -> dict[str, NoiseTexture]:
    """The textures of ``assets/mjcf/textures.toml`` by name, in file order.

    Raises:
        FogsimError: The file has an unknown or missing key (the message names the texture).
    """
    with TEXTURES_FILE.open("rb") as file:
        tables = tomllib.load(file)
    textures = {}
    for name, table in tables.items():
        try:
            textures[name] = NoiseTexture(**table)
        except TypeError as error:
            raise FogsimError(f"{TEXTURES_FILE}: texture {name!r}: {error}") from error
    return textures
