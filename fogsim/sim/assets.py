"""MJCF pieces shipped as data (``assets/mjcf/<name>.xml``), loaded as ``dm_control.mjcf`` models.

A piece is a small MJCF file holding one part of the scene: render and depth-buffer settings
(``visual``), lights (``lighting``), textures and materials (``materials``), the ground
(``floor``) and the free camera rig (``camera_rig``). Each file says what it holds and why.
A scene merges pieces into its root with ``root.include_copy(load_mjcf_piece(name))``: the
elements keep their names (no ``piece/`` prefix, no attachment frame), in file order.
"""

from __future__ import annotations

from dm_control import mjcf

from fogsim.errors import FogsimError
from fogsim.paths import ASSETS_DIR

MJCF_DIR = ASSETS_DIR / "mjcf"
"""Folder of the MJCF pieces."""


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
    return mjcf.from_path(str(path), resolve_references=False)
