"""The pinocchio → MJCF converter and its on-disk cache.

The MuJoCo model is generated *from the pinocchio model* (joint placements, axes, inertias,
geometry placements), so both agree on joint zeros and axes by construction. Meshes are taken
from the geometry pinocchio loaded (coal meshes). The model is one MJCF file in a cache directory
(``~/.cache/fogsim/robots/<name>/``, root overridable by the environment variable
``FOGSIM_CACHE``) whose name carries a digest of everything the text depends on, and its meshes
are MuJoCo's binary ``.msh`` files in the folder of the same name beside it (``<compiler
meshdir>``): MuJoCo then parses no long numeric text, whose parse a stray ``errno`` can fail
(:mod:`fogsim.robot.mj_xml`), and the iCub's XML is 30 kB, not 3.5 MB.

The text is built with ElementTree, not ``dm_control.mjcf`` (which the scene uses to assemble
the world): numbers are written with ``repr`` so MuJoCo reads back pinocchio's doubles bit for
bit (mesh vertices are float32 in MuJoCo, as in the ``.msh`` file); ``dm_control.mjcf`` writes
every float at a fixed precision, adds ``class`` attributes and reorders attributes, so the same
robot would give another text.
"""

import hashlib
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import coal
import mujoco
import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from fogsim.atomic import write_atomic, write_text_atomic
from fogsim.errors import RobotModelError
from fogsim.geometry import MJ_FROM_CV
from fogsim.robot.description import CAMERA_NAMES, RobotDescription
from fogsim.robot.meshes import mesh_faces, mesh_vertices_m
from fogsim.robot.mj_xml import mesh_file

_CACHE_FORMAT_VERSION = 4
"""Bump when the generated MJCF changes, so stale cache files are rebuilt."""
MIN_BODY_MASS_KG = 1e-3
"""Lightest body MuJoCo gets [kg]: URDF links without mass (frames, sensors) would not simulate."""
MIN_PRINCIPAL_INERTIA_KGM2 = 1e-6
"""Added to an inertia whose smallest principal moment is below it [kg m²], for the same reason."""
CAMERA_FOVY_DEG = 39.0
"""Vertical field of view of the MJCF cameras [deg] (the scene may set its own)."""
_SAFE_FILE_NAME = re.compile(r"[A-Za-z0-9_.-]+")
"""A mesh's file name is its MJCF name: of these characters only (no folder, no space)."""


def cache_root() -> Path:
    """Directory holding generated robot models (``$FOGSIM_CACHE/robots`` or ~/.cache)."""
    base = os.environ.get("FOGSIM_CACHE")
    root = Path(base) if base else Path.home() / ".cache" / "fogsim"
    return root / "robots"


def cached_mjcf(
    description: RobotDescription,
    model: pin.Model,
    geometry_model: pin.GeometryModel,
    urdf_path: str,
) -> Path:
    """Path of the robot's MJCF file in the cache, generated (atomically) if it is not there yet.

    Args:
        description: The robot's description.
        model: Its pinocchio model, camera frames added.
        geometry_model: The geometries MuJoCo renders.
        urdf_path: The URDF the pinocchio model was loaded from (part of the digest).
    """
    name = description.name
    digest = _source_digest(description, urdf_path)
    path = cache_root() / name / f"{name}_{digest}.xml"
    if not all(p.exists() for p in mjcf_files(path)):  # the XML last, so it implies its meshes
        text, meshes = build_mjcf(description, model, geometry_model, path.stem)
        for file_name, content in meshes.items():
            write_atomic(path.parent / file_name, lambda f, data=content: f.write(data))
        write_text_atomic(path, text)
    return path


def mjcf_files(path: Path) -> list[Path]:
    """The robot MJCF file ``path`` and the mesh files it names, in the XML's order.

    Just ``[path]`` if the file does not exist. Its mesh files lie in the folder of its
    ``<compiler meshdir>`` beside it (:func:`build_mjcf`); together they are the robot model
    MuJoCo and ``dm_control`` load, so content keys read them all.
    """
    if not path.exists():
        return [path]
    tree = ET.parse(path)
    compiler = tree.find("compiler")
    mesh_dir = path.parent / (compiler.get("meshdir", "") if compiler is not None else "")
    return [path, *(mesh_dir / mesh.get("file") for mesh in tree.iter("mesh") if mesh.get("file"))]


def _source_digest(description: RobotDescription, urdf_path: str) -> str:
    digest = hashlib.sha256()
    digest.update(Path(urdf_path).read_bytes())
    digest.update(repr((description, _CACHE_FORMAT_VERSION, mujoco.__version__)).encode())
    return digest.hexdigest()[:16]


def build_mjcf(
    description: RobotDescription,
    model: pin.Model,
    geometry_model: pin.GeometryModel,
    mesh_dir: str,
) -> tuple[str, dict[str, bytes]]:
    """Generate the MJCF text of a robot from its pinocchio model, and its mesh files.

    Numbers are written with full precision so that MuJoCo and pinocchio agree to 1e-12.

    Args:
        description: The robot's description.
        model: Its pinocchio model, camera frames added.
        geometry_model: The geometries MuJoCo renders.
        mesh_dir: The folder of the mesh files, relative to the MJCF file's
            (``<compiler meshdir>``).

    Returns:
        The MJCF text and its mesh files: path relative to the MJCF file's folder → contents
        (MuJoCo's binary ``.msh``, :func:`fogsim.robot.mj_xml.mesh_file`).
    """
    root = ET.Element("mujoco", model=description.name)
    ET.SubElement(
        root, "compiler", angle="radian", autolimits="true", fusestatic="false", meshdir=mesh_dir
    )
    visual = ET.SubElement(root, "visual")
    ET.SubElement(visual, "global", offwidth="640", offheight="480")
    asset = ET.SubElement(root, "asset")
    worldbody = ET.SubElement(root, "worldbody")
    body_names = _body_names(model)
    bodies = [worldbody]
    for joint_id in range(1, model.njoints):
        placement = model.jointPlacements[joint_id]
        body = ET.SubElement(
            bodies[model.parents[joint_id]],
            "body",
            name=body_names[joint_id],
            pos=_fmt(placement.translation),
            quat=_fmt(_quat_wxyz(placement.rotation)),
        )
        mass, lever, full = _bounded_inertia(model.inertias[joint_id])
        ET.SubElement(body, "inertial", pos=_fmt(lever), mass=repr(mass), fullinertia=_fmt(full))
        joint_model = model.joints[joint_id]
        if joint_model.shortname() == "JointModelFreeFlyer":
            ET.SubElement(body, "freejoint", name="root")
        else:
            idx = joint_model.idx_q
            limits = [model.lowerPositionLimit[idx], model.upperPositionLimit[idx]]
            ET.SubElement(
                body,
                "joint",
                name=model.names[joint_id],
                type="hinge",
                axis=_fmt(_joint_axis(joint_model)),
                range=_fmt(limits),
            )
        bodies.append(body)
    fix_y_up = description.quirks.fix_y_up_meshes
    meshes: dict[str, bytes] = {}
    for geometry_object in geometry_model.geometryObjects:
        body = bodies[geometry_object.parentJoint]
        meshes.update(_add_geometry(asset, body, geometry_object, fix_y_up))
    # Every other pinocchio frame becomes a site of the same name (l_sole, head_camera, ...).
    for frame in model.frames:
        if frame.type in (pin.FrameType.JOINT, pin.FrameType.FIXED_JOINT):
            continue
        if frame.parentJoint == 0 or (
            frame.type == pin.FrameType.BODY and frame.name in body_names
        ):
            continue
        ET.SubElement(
            bodies[frame.parentJoint],
            "site",
            name=frame.name,
            pos=_fmt(frame.placement.translation),
            quat=_fmt(_quat_wxyz(frame.placement.rotation)),
            size="0.005",
            group="4",
        )
    camera_joint = model.getJointId(description.camera.parent_joint)
    for name in CAMERA_NAMES:
        placement = model.frames[model.getFrameId(name)].placement
        ET.SubElement(
            bodies[camera_joint],
            "camera",
            name=name,
            pos=_fmt(placement.translation),
            quat=_fmt(_quat_wxyz(placement.rotation @ MJ_FROM_CV)),
            fovy=repr(CAMERA_FOVY_DEG),
        )
    ET.indent(root)
    return ET.tostring(root, encoding="unicode"), {f"{mesh_dir}/{k}": v for k, v in meshes.items()}


def _body_names(model: pin.Model) -> list[str]:
    """MuJoCo body name of each pinocchio joint: its first BODY frame (the URDF child link)."""
    names = ["world"]
    for joint_id in range(1, model.njoints):
        candidates = [
            f.name
            for f in model.frames
            if f.parentJoint == joint_id and f.type == pin.FrameType.BODY
        ]
        names.append(candidates[0] if candidates else f"{model.names[joint_id]}_body")
    return names


def _add_geometry(
    asset: ET.Element, body: ET.Element, geometry_object: pin.GeometryObject, fix_y_up: bool
) -> dict[str, bytes]:
    """One geom (and, for a mesh, its mesh asset) for a pinocchio geometry object.

    Returns:
        For a mesh, its file (name in the mesh folder → ``.msh`` contents); else nothing.

    Raises:
        RobotModelError: The geometry's type is not supported, or a mesh's name is no safe
            file name.
    """
    geometry = geometry_object.geometry
    name = geometry_object.name
    placement = geometry_object.placement
    rgba = np.asarray(geometry_object.meshColor, dtype=np.float64)
    if not np.all(np.isfinite(rgba)) or rgba[3] <= 0.0 or rgba[:3].max() < 0.15:
        rgba = np.array([0.72, 0.72, 0.76, 1.0])  # URDF black/unset: a light grey to see it
    attributes = {
        "name": name,
        "pos": _fmt(placement.translation),
        "quat": _fmt(_quat_wxyz(placement.rotation)),
        "rgba": _fmt(rgba),
        "contype": "0",
        "conaffinity": "0",
        "group": "1",
    }
    if isinstance(geometry, coal.BVHModelBase):
        file_name = f"{name}_mesh.msh"
        if not _SAFE_FILE_NAME.fullmatch(file_name):
            raise RobotModelError(f"mesh {name!r}: not a safe file name for its .msh file")
        ET.SubElement(asset, "mesh", name=f"{name}_mesh", file=file_name, inertia="shell")
        ET.SubElement(body, "geom", type="mesh", mesh=f"{name}_mesh", **attributes)
        vertices = mesh_vertices_m(geometry_object, fix_y_up)
        return {file_name: mesh_file(vertices, mesh_faces(geometry_object))}
    if isinstance(geometry, coal.Box):
        ET.SubElement(body, "geom", type="box", size=_fmt(geometry.halfSide), **attributes)
    elif isinstance(geometry, coal.Cylinder | coal.Capsule):
        kind = "cylinder" if isinstance(geometry, coal.Cylinder) else "capsule"
        size = _fmt([geometry.radius, geometry.halfLength])
        ET.SubElement(body, "geom", type=kind, size=size, **attributes)
    elif isinstance(geometry, coal.Sphere):
        ET.SubElement(body, "geom", type="sphere", size=_fmt([geometry.radius]), **attributes)
    else:
        raise RobotModelError(f"unsupported geometry {type(geometry).__name__} in {name}")
    return {}


def _joint_axis(joint_model: pin.JointModel) -> NDArray[np.float64]:
    """Rotation axis of a revolute joint in its own frame."""
    short = joint_model.shortname()
    axes = {"JointModelRX": (1, 0, 0), "JointModelRY": (0, 1, 0), "JointModelRZ": (0, 0, 1)}
    if short in axes:
        return np.array(axes[short], dtype=np.float64)
    if short == "JointModelRevoluteUnaligned":
        return np.asarray(joint_model.extract().axis, dtype=np.float64)
    raise RobotModelError(f"unsupported joint type {short} (revolute joints only)")


def _quat_wxyz(rotation: NDArray[np.float64]) -> NDArray[np.float64]:
    """MuJoCo quaternion (w, x, y, z) of a 3×3 rotation."""
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=np.float64).reshape(9))
    return quat


def _bounded_inertia(
    inertia: pin.Inertia,
) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
    """Mass [kg], centre of mass [m] and (xx, yy, zz, xy, xz, yz) inertia [kg m²], bounded below."""
    mass = max(float(inertia.mass), MIN_BODY_MASS_KG)
    matrix = 0.5 * (inertia.inertia + inertia.inertia.T)
    if np.linalg.eigvalsh(matrix).min() < MIN_PRINCIPAL_INERTIA_KGM2:
        matrix = matrix + MIN_PRINCIPAL_INERTIA_KGM2 * np.eye(3)
    full = np.array(
        [matrix[0, 0], matrix[1, 1], matrix[2, 2], matrix[0, 1], matrix[0, 2], matrix[1, 2]]
    )
    return mass, np.asarray(inertia.lever, dtype=np.float64), full


def _fmt(values: ArrayLike) -> str:
    """Space-separated floats that read back bit for bit (MuJoCo's own writer keeps 6 digits)."""
    return " ".join(repr(float(v)) for v in np.asarray(values, dtype=np.float64).reshape(-1))
