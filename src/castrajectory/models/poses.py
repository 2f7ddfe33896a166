"""Poses of bodies for :mod:`~castrajectory.models.multibody`: orientations in the plane (an angle) and in space (a
unit quaternion on the package's quadratic rotation map), composed, compared and turned about an axis by one
interface, so that one kinematics serves both; and the checks of the builder's geometric input (points, axes,
rotations, inertias)."""
from __future__ import annotations

from typing import Tuple

import casadi as ca
import numpy as np

from ..validation import InputError, finite, positive
from .rigidbody import quat_conjugate, quat_multiply, rotation


# ----------------------------------------------------------------------------- the plane and space
class Plane:
    """Orientations in the plane: an angle (a 1-vector); rotations ``R(θ)``."""

    dim, nori = 2, 1
    axes = ("x", "y")
    ori_names = ("theta",)
    identity = (0.0,)

    @staticmethod
    def R(ori):
        c, s = ca.cos(ori[0]), ca.sin(ori[0])
        return ca.vertcat(ca.horzcat(c, -s), ca.horzcat(s, c))

    @staticmethod
    def compose(a, b):
        return a + b

    @staticmethod
    def relative(a, b):
        """The orientation of ``b`` in ``a``'s frame."""
        return b - a

    @staticmethod
    def hinge(axis, angle):
        return ca.vertcat(angle)

    @staticmethod
    def hinge_angle(rel, axis):
        return rel[0]

    @staticmethod
    def weld_rows(rel):
        return [rel[0]]

    @staticmethod
    def axis_rows(rel, axis):
        return []

    @staticmethod
    def normals(axis):
        return [np.array([-axis[1], axis[0]])]

    @staticmethod
    def spin(ori, rate):
        """½ × the body's rotational kinetic energy per unit inertia is ``½ θ̇²``: the angle's rate."""
        return rate[0]


class Space:
    """Orientations in space: a quaternion ``(w, x, y, z)`` (unit by a constraint), the quadratic rotation map
    :func:`~castrajectory.models.rigidbody.rotation`."""

    dim, nori = 3, 4
    axes = ("x", "y", "z")
    ori_names = ("qw", "qx", "qy", "qz")
    identity = (1.0, 0.0, 0.0, 0.0)

    @staticmethod
    def R(ori):
        return rotation(ori)

    @staticmethod
    def compose(a, b):
        return quat_multiply(a, b)

    @staticmethod
    def relative(a, b):
        return quat_multiply(quat_conjugate(a), b)

    @staticmethod
    def hinge(axis, angle):
        return ca.vertcat(ca.cos(angle / 2), ca.sin(angle / 2) * ca.DM(axis))

    @staticmethod
    def hinge_angle(rel, axis):
        return 2 * ca.atan2(ca.dot(rel[1:4], ca.DM(axis)), rel[0])

    @staticmethod
    def weld_rows(rel):
        return [rel[1], rel[2], rel[3]]

    @staticmethod
    def axis_rows(rel, axis):
        """A relative rotation about ``axis`` has its vector part along it: two rows, bilinear in the
        quaternions."""
        return [ca.dot(rel[1:4], ca.DM(n)) for n in Space.normals(axis)]

    @staticmethod
    def normals(axis):
        a = np.asarray(axis, float)
        t = np.eye(3)[int(np.argmin(np.abs(a)))]
        n1 = np.cross(a, t)
        n1 /= np.linalg.norm(n1)
        return [n1, np.cross(a, n1)]


GEOMETRY = {2: Plane, 3: Space}


def checked_vector(value, n: int, what: str) -> Tuple[float, ...]:
    try:
        v = np.asarray(value, float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be {n} numbers (got {value!r})") from None
    if v.size != n or not np.all(np.isfinite(v)):
        raise InputError(f"{what} must be {n} finite numbers (got {value!r})")
    return tuple(float(x) for x in v)


def unit_vector(value, n: int, what: str) -> Tuple[float, ...]:
    v = np.asarray(checked_vector(value, n, what))
    if not np.linalg.norm(v) > 0:
        raise InputError(f"the {what} must be nonzero")
    return tuple(float(x) for x in v / np.linalg.norm(v))


def matrix_quaternion(R) -> np.ndarray:
    """The unit quaternion ``(w, x, y, z)`` (``w ≥ 0``) of a rotation matrix (Shepperd's method).

    >>> import numpy as np
    >>> from castrajectory.models.poses import matrix_quaternion
    >>> np.round(matrix_quaternion([[0, -1, 0], [1, 0, 0], [0, 0, 1]]), 12).tolist()   # 90° about z
    [0.707106781187, 0.0, 0.0, 0.707106781187]
    """
    R = np.asarray(R, float)
    w = np.sqrt(max(0.0, 1.0 + np.trace(R))) / 2
    d = np.sqrt(np.maximum(0.0, 1.0 + 2 * np.diag(R) - np.trace(R))) / 2
    i = int(np.argmax([w, *d]))
    if i == 0:
        q = np.array([w, (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)])
    else:
        k = i - 1
        a, b = (k + 1) % 3, (k + 2) % 3
        v = np.zeros(3)
        v[k] = d[k]
        v[a] = (R[a, k] + R[k, a]) / (4 * d[k])
        v[b] = (R[b, k] + R[k, b]) / (4 * d[k])
        q = np.array([(R[b, a] - R[a, b]) / (4 * d[k]), *v])
    q = q / np.linalg.norm(q)
    return q if q[0] >= 0 else -q


def checked_rotation(value, dim: int, what: str) -> Tuple[float, ...]:
    """A joint's rotation: an angle in the plane; in space a quaternion ``(w, x, y, z)`` (normalised) or a 3 × 3
    rotation matrix."""
    if dim == 2:
        return (finite(what, value),)
    arr = np.asarray(value, float) if not isinstance(value, str) else np.array([np.nan])
    if arr.shape == (3, 3):
        if not (np.all(np.isfinite(arr)) and np.allclose(arr @ arr.T, np.eye(3), atol=1e-9)
                and np.linalg.det(arr) > 0):
            raise InputError(f"the {what} is not a rotation matrix (orthonormal, determinant 1)")
        return tuple(float(x) for x in matrix_quaternion(arr))
    return unit_vector(value, 4, f"{what} (a quaternion w, x, y, z)")


def checked_inertia(value, dim: int, name: str):
    """A body's inertia about its centre of mass: a number in the plane; in space 3 principal moments along the
    body's axes or a symmetric 3 × 3 matrix, positive definite and obeying the triangle inequality."""
    if dim == 2:
        return positive(f"inertia of {name}", value)
    arr = np.asarray(value, float)
    if arr.shape == (3,):
        arr = np.diag(arr)
    symmetric = arr.shape == (3, 3) and np.all(np.isfinite(arr)) and np.allclose(arr, arr.T, atol=1e-12 * np.abs(arr).max())
    if not symmetric:
        raise InputError(f"inertia of {name} must be 3 principal moments or a symmetric 3x3 matrix (got {value!r})")
    moments = np.linalg.eigvalsh(arr)
    if moments[0] <= 0:
        raise InputError(f"inertia of {name} must be positive definite (its principal moments are "
                         f"{', '.join(f'{m:g}' for m in moments)})")
    if moments[0] + moments[1] < moments[2] * (1 - 1e-9):
        raise InputError(f"inertia of {name}: no mass distribution has the principal moments "
                         f"{', '.join(f'{m:g}' for m in moments)} (the triangle inequality I₁ + I₂ ≥ I₃)")
    return tuple(tuple(float(x) for x in row) for row in 0.5 * (arr + arr.T))
