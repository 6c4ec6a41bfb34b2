"""The camera in the base frame from ``sensor_msgs/JointState`` through the robot's URDF.

For robots whose bags carry joint states but no camera transforms on ``/tf``: pinocchio builds
the kinematic model from the URDF text; per depth image every joint on the chain between the
base frame and the camera's frame is interpolated linearly at the image's stamp between its
samples around it (the nearest within the tolerance, :func:`fogsim.bags.tf.bracket`) and the
forward kinematics give ``T_base_camera``. Joint states may come in several messages (one per
publisher); each joint is interpolated on its own samples. Revolute and prismatic joints take
one position, continuous joints (``cos``, ``sin`` in pinocchio's configuration) their angle;
joints off the chain stay at their neutral position.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from fogsim.bags.tf import bracket, frame_name, last_per_stamp
from fogsim.bags.topics import BagError


@dataclass(frozen=True)
class JointSample:
    """One joint's position in a ``sensor_msgs/JointState`` message.

    Attributes:
        stamp_ns: The message's ``header.stamp`` [ns].
        name: The joint's name.
        position: Its position [rad or m].
    """

    stamp_ns: int
    name: str
    position: float


class UrdfChain:
    """Forward kinematics of a URDF between two of its frames."""

    def __init__(self, urdf_text: str, where: str) -> None:
        """Build the model.

        Args:
            urdf_text: The URDF file's text.
            where: Names the file in errors.

        Raises:
            BagError: The text is not a URDF pinocchio reads.
        """
        try:
            self.model = pin.buildModelFromXML(urdf_text)
        except (ValueError, RuntimeError) as exc:
            raise BagError(f"{where}: not a URDF model pinocchio can read: {exc}") from exc
        self.where = where

    def _frame_id(self, name: str) -> int:
        """Pinocchio's id of the link or frame ``name``."""
        if not self.model.existFrame(name):
            links = sorted({f.name for f in self.model.frames} - {"universe"})
            raise BagError(f"{self.where}: no link or frame {name!r}; it has {links}")
        return int(self.model.getFrameId(name))

    def _chain_joints(self, frame_id: int) -> list[int]:
        """The ids of the joints from the root down to the frame (the universe left out)."""
        joints, joint = [], int(self.model.frames[frame_id].parentJoint)
        while joint > 0:
            joints.append(joint)
            joint = int(self.model.parents[joint])
        return joints

    def transforms(
        self,
        parent: str,
        child: str,
        samples: Sequence[JointSample],
        stamps_ns: NDArray[np.int64],
        max_dt_ns: int,
    ) -> NDArray[np.float64]:
        """(N, 4, 4) ``T_parent_child`` at each stamp from the joints' samples.

        Raises:
            BagError: A frame not in the URDF, a joint on the chain without samples (or none
                within the tolerance of a stamp), a joint of more than one degree of freedom.
        """
        parent_id, child_id = self._frame_id(frame_name(parent)), self._frame_id(frame_name(child))
        needed = sorted(set(self._chain_joints(parent_id)) | set(self._chain_joints(child_id)))
        configurations = np.tile(pin.neutral(self.model), (len(stamps_ns), 1))
        for joint_id in needed:
            name = self.model.names[joint_id]
            joint = self.model.joints[joint_id]
            positions = _joint_at(name, samples, stamps_ns, max_dt_ns)
            if joint.nq == 1:
                configurations[:, joint.idx_q] = positions
            elif joint.nq == 2 and joint.nv == 1:  # continuous: (cos, sin) of the angle
                configurations[:, joint.idx_q] = np.cos(positions)
                configurations[:, joint.idx_q + 1] = np.sin(positions)
            else:
                raise BagError(
                    f"{self.where}: joint {name!r} ({joint.shortname()}) has {joint.nv} degrees "
                    "of freedom; joint states give revolute, continuous and prismatic joints"
                )
        data = self.model.createData()
        out = np.empty((len(stamps_ns), 4, 4))
        for i, q in enumerate(configurations):  # one forward kinematics per image
            pin.framesForwardKinematics(self.model, data, q)
            out[i] = (data.oMf[parent_id].inverse() * data.oMf[child_id]).homogeneous
        return out


def _joint_at(
    name: str, samples: Sequence[JointSample], stamps_ns: NDArray[np.int64], max_dt_ns: int
) -> NDArray[np.float64]:
    """(N,) the joint's position at each stamp, linearly interpolated between its samples."""
    own = [s for s in samples if s.name == name]
    if not own:
        names = sorted({s.name for s in samples})
        raise BagError(f"joint {name!r} has no joint states; the bag's joints: {names}")
    stamps = np.array([s.stamp_ns for s in own], dtype=np.int64)
    positions = np.array([s.position for s in own], dtype=np.float64)
    keep = last_per_stamp(stamps)
    if not np.all(np.isfinite(positions[keep])):
        raise BagError(f"joint {name!r}: a joint state position is not finite")
    lo, hi, u = bracket(stamps[keep], stamps_ns, max_dt_ns, f"joint {name!r}")
    return (1.0 - u) * positions[keep][lo] + u * positions[keep][hi]
