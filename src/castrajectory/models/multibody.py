"""Multibody systems from bodies and joints (issue 45): planar (``dim=2``) or spatial (``dim=3``) bodies whose systems
come in two formulations of the same physics.

* ``"maximal"`` (the default): every body its own coordinates, the position of its centre of mass and its
  orientation (an angle in the plane; a unit quaternion ``(w, x, y, z)`` in space, with its norm a constraint), and
  every joint a few holonomic constraints between the two bodies it joins.  A system's unknowns, rows and their
  derivatives grow linearly with the bodies: each row touches two bodies.
* ``"joint"``: a tree's joint coordinates (an angle per revolute joint, a displacement per prismatic one, a unit
  quaternion per spherical joint, the pose of a free body), the bodies' positions and orientations built by
  recursive kinematics.  Its mass matrix is dense, with entries along the whole path from the root, so its rows and
  their derivatives grow as the square of the bodies and worse.  It is kept for comparison; it is what a chain
  written by hand in its angles is, and it is the coordinates of a model file (:mod:`.model_files`).

Joints: ``revolute`` (a point of the parent and a point of the child coincide; in space the child turns about an
axis), ``prismatic`` (the child slides along an axis without turning), ``spherical`` (in space: the points coincide,
any relative rotation), ``weld`` (fixed), and none (a free body).  A joint's ``rotation`` is the child's orientation
relative to the parent where the joint's coordinate is zero (an angle in the plane, a quaternion or a rotation matrix
in space).  The parent may be :attr:`Multibody.world` (the fixed base).  A joint whose child already has a parent
closes a loop: it is a constraint in both formulations.  A body moved by several joints in sequence (a model file's
body with a slide and a hinge) is joined by :meth:`Multibody.compound`, in joint coordinates.

An n-link chain of uniform rods, hanging from the origin, its links at 0.5 rad:

>>> import castrajectory as ct
>>> mb = ct.Multibody(g=9.81)
>>> parent = mb.world
>>> for i in range(3):
...     link = mb.body(f"link{i + 1}", mass=1.0, inertia=1.0 / 12, outline=[(0.0, 0.5), (0.0, -0.5)])
...     _ = mb.revolute(parent, link, parent_point=(0.0, 0.0) if i == 0 else (0.0, -0.5), child_point=(0.0, 0.5))
...     parent = link
>>> system = mb.system()
>>> system.nq, len(system.constraints)
(9, 6)
>>> q0, qd0 = mb.state([0.5, 0.0, 0.0])           # the joint angles (relative), at rest
>>> run = ct.simulate(system, q0, qd0, T=1.0, N=40, scheme="galerkin4")
>>> joint = ct.simulate(mb.system("joint"), *mb.state([0.5, 0.0, 0.0], formulation="joint"), T=1.0, N=40,
...                     scheme="galerkin4")
>>> bool(abs(mb.joint_positions(run.q[-1]) - joint.q[-1]).max() < 1e-5)   # two discretisations, one motion
True
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import casadi as ca
import numpy as np

from ..validation import InputError, finite, positive
from .mechanics import Dissipation, Force, Gravity, LagrangianSystem, Potential, velocity
from .poses import GEOMETRY, Space, checked_inertia, checked_rotation, checked_vector, unit_vector
from .rigidbody import rotation, unit_norm

#: a one-coordinate joint's options: a viscous damping, a spring's stiffness and rest position, an armature (the
#: rotor inertia a model file adds to the coordinate), the coordinate's limits (lower, upper), and the coordinate's
#: value where the joint is at its zero pose (MJCF's ``ref``)
JOINT_OPTIONS = ("damping", "stiffness", "rest", "armature", "limits", "zero")
#: the formulations of :meth:`Multibody.system`
FORMULATIONS = ("maximal", "joint")
#: the joint kinds and the coordinates each gives the joint formulation (in space; a planar joint has the same
#: count, and no spherical joint)
JOINT_KINDS = {"revolute": 1, "prismatic": 1, "spherical": 4, "weld": 0}


@dataclass(frozen=True)
class Body:
    """A rigid body: its ``mass``, its ``inertia`` about its centre of mass (a number in the plane; in space a
    3 × 3 matrix in the body's axes), the centre of mass ``com`` in the body's frame, and ``outline``, body-frame
    points drawn joined in order (its pictures)."""

    name: str
    mass: float
    inertia: object
    com: Tuple[float, ...] = (0.0, 0.0)
    outline: Tuple[Tuple[float, ...], ...] = ()
    index: int = -1

    @property
    def second_moment(self) -> np.ndarray:
        """``S = ∫ d dᵀ dm = ½ tr(I) 𝟙 − I`` about the centre of mass (in space): ``K_rot = ½ tr(Ṙ S Ṙᵀ)``."""
        inertia = np.asarray(self.inertia, float)
        return 0.5 * np.trace(inertia) * np.eye(3) - inertia


@dataclass(frozen=True)
class Joint:
    """A joint of ``kind`` between ``parent`` (None: the world) and ``child``, at ``parent_point`` (the parent's
    frame; the world's for the base) and ``child_point`` (the child's frame); ``axis`` (the joint frame's: the
    child's, turned by ``rotation`` from the parent's) a revolute joint's axis in space or a prismatic joint's
    direction; ``rotation`` the child's orientation in the parent's where the coordinate is zero; ``tree``: False
    where it closes a loop.  ``parts``: a compound joint's elementary joints ``(kind, axis, point)`` (the point in
    the child's frame), applied in order from the child's pose ``parent_point``, ``rotation`` in the parent."""

    name: str
    kind: str
    parent: Optional[Body]
    child: Body
    parent_point: Tuple[float, ...]
    child_point: Tuple[float, ...]
    axis: Tuple[float, ...] = (1.0, 0.0)
    rotation: Tuple[float, ...] = (0.0,)
    tree: bool = True
    parts: Tuple = ()
    #: a one-coordinate joint's options (:data:`JOINT_OPTIONS`)
    damping: float = 0.0
    stiffness: float = 0.0
    rest: float = 0.0
    armature: float = 0.0
    limits: Optional[Tuple[float, float]] = None
    zero: float = 0.0
    #: a compound joint's parts' coordinate names and options (damping, stiffness, rest, armature, limits)
    part_names: Tuple = ()
    part_options: Tuple = ()

    @property
    def compound(self) -> bool:
        return bool(self.parts)

    def options(self) -> List[Tuple[int, dict]]:
        """The options of the joint's one-coordinate elements: ``(element index, options)``."""
        if self.parts:
            return [(k, o) for k, o in enumerate(self.part_options) if o]
        own = {k: getattr(self, k) for k in JOINT_OPTIONS if getattr(self, k)}
        return [(0, own)] if own else []

    def zero_of(self, k: int) -> float:
        """Element ``k``'s coordinate at the joint's zero pose (its ``zero`` option)."""
        return dict(self.options()).get(k, {}).get("zero", 0.0)

    def elements(self):
        """The elementary joints ``(kind, axis, point)`` applied from the child's zero pose."""
        if self.parts:
            return self.parts
        return () if self.kind == "weld" else ((self.kind, self.axis, self.child_point),)


@dataclass
class Multibody:
    """Bodies joined by joints (module doc), in the plane (``dim=2``, gravity along −y) or in space (``dim=3``,
    gravity along −z; ``g`` a number or the gravity vector); :meth:`system` the :class:`LagrangianSystem`,
    :meth:`state` an initial state from joint coordinates, :meth:`joint_positions` the joint coordinates of a
    maximal state.

    A uniform rod hung by its top end (its centre of mass 0.5 below the pin): three coordinates and two pin rows in
    maximal coordinates, one angle in joint coordinates, the same energy −m g (l/2) cos φ:

    >>> import castrajectory as ct
    >>> mb = ct.Multibody(g=9.81)
    >>> rod = mb.body("rod", mass=1.0, inertia=1.0 / 12, outline=[(0.0, 0.5), (0.0, -0.5)])
    >>> pin = mb.revolute(mb.world, rod, child_point=(0.0, 0.5), name="pin")
    >>> system = mb.system()
    >>> system.nq, len(system.constraints), mb.system("joint").nq
    (3, 2, 1)
    >>> q0, qd0 = mb.state({"pin": 0.5})
    >>> round(float(system.energy(q0, qd0)), 6)      # −9.81 · 0.5 · cos 0.5
    -4.304542
    >>> run = ct.simulate(system, q0, qd0, T=1.0, N=20, scheme="galerkin4")
    >>> run.success, bool(abs(run.energy - run.energy[0]).max() < 1e-5)   # (measured 2.6e-6)
    (True, True)

    The same rod in space, on a hinge about x: seven coordinates per body (its centre of mass and a quaternion),
    three point rows, two axis rows and the quaternion's norm:

    >>> mb3 = ct.Multibody(g=9.81, dim=3)
    >>> rod3 = mb3.body("rod", mass=1.0, inertia=[1 / 12, 1 / 12, 1e-3], outline=[(0, 0, 0.5), (0, 0, -0.5)])
    >>> _ = mb3.revolute(mb3.world, rod3, child_point=(0.0, 0.0, 0.5), axis=(1.0, 0.0, 0.0), name="pin")
    >>> mb3.system().nq, len(mb3.system().constraints)
    (7, 6)
    >>> round(float(mb3.system().energy(*mb3.state({"pin": 0.5}))), 6)
    -4.304542
    """

    g: object = 9.81
    dim: int = 2
    bodies: List[Body] = field(default_factory=list)
    joints: List[Joint] = field(default_factory=list)
    #: a free body's coordinates' prefix, by body name (its own name by default; a model file's free joint's)
    free_names: Dict[str, str] = field(default_factory=dict)
    #: joint coordinates by name that :meth:`state` starts from where none are given (a model file's ``qpos0``)
    defaults: Dict[str, float] = field(default_factory=dict)

    #: the fixed base, a parent for the joints that hold a body to the world
    world = None

    def __post_init__(self):
        if self.dim not in GEOMETRY:
            raise InputError(f"dim must be 2 (planar) or 3 (spatial) (got {self.dim!r})")
        self._geo = GEOMETRY[self.dim]
        if np.ndim(self.g) == 0:
            g = finite("g", self.g)
            self.gravity = -g * np.eye(self.dim)[-1]
        else:
            self.gravity = np.asarray(checked_vector(self.g, self.dim, "the gravity vector"))

    # ------------------------------------------------------------------ building
    def body(self, name: str, mass: float, inertia, com=None, outline: Sequence = ()) -> Body:
        """A new body (a unique ``name``; ``mass`` positive, ``inertia`` about the centre of mass: a positive number
        in the plane, 3 principal moments along the body's axes or a 3 × 3 matrix in space)."""
        name = str(name)
        d = self.dim
        if any(b.name == name for b in self.bodies):
            raise InputError(f"a body named {name!r} exists already")
        b = Body(name, positive(f"mass of {name}", mass), checked_inertia(inertia, d, name),
                 checked_vector(np.zeros(d) if com is None else com, d, f"com of {name}"),
                 tuple(checked_vector(p, d, f"outline point of {name}") for p in outline), len(self.bodies))
        self.bodies.append(b)
        return b

    def revolute(self, parent: Optional[Body], child: Body, parent_point=None, child_point=None, axis=None,
                 rotation=None, name: Optional[str] = None, **options) -> Joint:
        """A pin: ``parent_point`` of the parent and ``child_point`` of the child coincide; its coordinate is the
        child's angle relative to the parent (0 where the child's orientation in the parent is ``rotation``), in
        space about ``axis`` (the child's frame; z by default)."""
        return self._joint("revolute", parent, child, parent_point, child_point, axis, rotation, name, options)

    def prismatic(self, parent: Optional[Body], child: Body, axis=None, parent_point=None, child_point=None,
                  rotation=None, name: Optional[str] = None, **options) -> Joint:
        """A slider: the child keeps its orientation ``rotation`` in the parent, and its ``child_point`` moves along
        ``axis`` (the child's frame: the parent's turned by ``rotation``) through ``parent_point``; its coordinate
        is the displacement along the unit axis."""
        return self._joint("prismatic", parent, child, parent_point, child_point, axis, rotation, name, options)

    def spherical(self, parent: Optional[Body], child: Body, parent_point=None, child_point=None, rotation=None,
                  name: Optional[str] = None, **options) -> Joint:
        """A ball joint (in space): the points coincide, any relative rotation; its coordinates are the
        quaternion of the child's orientation relative to ``rotation``, unit by a constraint."""
        if self.dim != 3:
            raise InputError("a spherical joint is a joint in space (Multibody(dim=3))")
        return self._joint("spherical", parent, child, parent_point, child_point, None, rotation, name, options)

    def weld(self, parent: Optional[Body], child: Body, parent_point=None, child_point=None, rotation=None,
             name: Optional[str] = None) -> Joint:
        """A fixed joint: the points coincide and the child keeps its orientation ``rotation`` in the parent."""
        return self._joint("weld", parent, child, parent_point, child_point, None, rotation, name, {})

    def compound(self, parent: Optional[Body], child: Body, parts: Sequence, position=None, rotation=None,
                 name: Optional[str] = None, names: Optional[Sequence[str]] = None) -> Joint:
        """Several joints in sequence (a model file's body with, say, two slides and a hinge): the child's pose
        in the parent is ``position``, ``rotation`` where the coordinates are zero, and each of ``parts``,
        ``(kind, axis, point[, options])`` with the axis and the point in the child's frame, moves it in turn (a
        revolute part turns it about the axis through the point, a prismatic part slides it along the axis, a
        spherical part turns it about the point); ``options`` as a joint's (damping, stiffness, rest, armature,
        limits).  Its coordinates follow the parts' order, named ``names`` (``name.k`` by default).  A tree
        joint only, in joint coordinates (:meth:`system` refuses it in maximal ones)."""
        d = self.dim
        checked, part_options = [], []
        for k, part in enumerate(parts):
            part = tuple(part) if isinstance(part, (tuple, list)) else (part,)
            if len(part) not in (3, 4):
                raise InputError(f"part {k} of a compound joint must be (kind, axis, point[, options]) "
                                 f"(got {part!r})")
            kind, axis, point = part[:3]
            if kind not in ("revolute", "prismatic", "spherical") or (kind == "spherical" and d != 3):
                raise InputError(f"part {k} of a compound joint: kind {kind!r} is not a joint with coordinates")
            axis = unit_vector(axis, d, f"axis of part {k}") if kind != "spherical" else (0.0,) * d
            checked.append((kind, axis, checked_vector(point, d, f"point of part {k}")))
            part_options.append(self._options(f"part {k} of {name}", dict(part[3]) if len(part) == 4 else {},
                                              JOINT_KINDS[kind]))
        if not checked:
            raise InputError("a compound joint needs at least one part (a weld has none: use weld)")
        names = tuple(str(n) for n in names) if names is not None else ()
        if names and len(names) != len(checked):
            raise InputError(f"a compound joint of {len(checked)} parts needs {len(checked)} names "
                             f"(got {len(names)})")
        if len(set(names)) != len(names) or set(self.joint_names()) & set(names):
            raise InputError(f"a compound joint's part names must be new and distinct (got {', '.join(names)})")
        j = self._joint("compound", parent, child, position, np.zeros(d), None, rotation, name, {}, tuple(checked))
        object.__setattr__(j, "part_names", names)
        object.__setattr__(j, "part_options", tuple(part_options))
        return j

    def _options(self, name: str, options: dict, ncoords: int) -> dict:
        """A joint's (or a part's) options checked: damping, stiffness and armature non-negative numbers, rest a
        number, limits (lower, upper); on a joint of one coordinate only."""
        unknown = sorted(set(options) - set(JOINT_OPTIONS))
        if unknown:
            raise InputError(f"unknown joint options {', '.join(unknown)} ({', '.join(JOINT_OPTIONS)})")
        extra = dict(options)
        for key in ("damping", "stiffness", "armature"):
            if key in extra:
                extra[key] = finite(f"{key} of joint {name}", extra[key])
                if extra[key] < 0:
                    raise InputError(f"{key} of joint {name} must not be negative (got {extra[key]:g})")
        for key in ("rest", "zero"):
            if key in extra:
                extra[key] = finite(f"{key} of joint {name}", extra[key])
        if extra.get("limits") is not None:
            lo, hi = checked_vector(extra["limits"], 2, f"limits of joint {name}")
            if not lo < hi:
                raise InputError(f"limits of joint {name} must be (lower, upper) with lower < upper")
            extra["limits"] = (lo, hi)
        if any(extra.get(k) for k in JOINT_OPTIONS) and ncoords != 1:
            raise InputError(f"joint {name}: {', '.join(JOINT_OPTIONS)} act on a joint of one coordinate (a "
                             f"revolute or prismatic joint)")
        return {k: v for k, v in extra.items() if v is not None}

    def _joint(self, kind, parent, child, pp, cp, axis, rotation, name, options, parts=()) -> Joint:
        d, geo = self.dim, self._geo
        for b, what in ((parent, "parent"), (child, "child")):
            foreign = not isinstance(b, Body) or b.index >= len(self.bodies) or self.bodies[b.index] is not b
            if b is not None and foreign:
                raise InputError(f"the joint's {what} is not a body of this Multibody (got {b!r})")
        if child is None:
            raise InputError("a joint's child is a body (the world is a parent only)")
        if parent is child:
            raise InputError(f"a joint joins two bodies ({child.name} to itself)")
        name = str(name) if name is not None else f"{kind}{len(self.joints) + 1}"
        if any(j.name == name for j in self.joints):
            raise InputError(f"a joint named {name!r} exists already")
        if axis is None:
            axis = np.eye(3)[2] if kind == "revolute" and d == 3 else np.eye(d)[0]
        axis = unit_vector(axis, d, f"{kind} axis") if kind == "prismatic" or (kind == "revolute" and d == 3) else \
            tuple(float(x) for x in axis)
        tree = not any(j.child is child and j.tree for j in self.joints)
        if tree and parent is not None and self._ancestor(child, parent):
            tree = False          # (it would make the child its own ancestor: a loop)
        if not tree and parts:
            raise InputError(f"joint {name}: a compound joint cannot close a loop")
        extra = self._options(name, options, JOINT_KINDS.get(kind, 0))
        if rotation is None:
            rotation = geo.identity[0] if d == 2 else geo.identity
        pp = checked_vector(np.zeros(d) if pp is None else pp, d, f"parent point of {name}")
        j = Joint(name, kind, parent, child, pp,
                  checked_vector(np.zeros(d) if cp is None else cp, d, f"child point of {name}"), axis,
                  checked_rotation(rotation, d, f"rotation of {name}"), tree, parts, **extra)
        self.joints.append(j)
        return j

    def _parent_joint(self, body: Body) -> Optional[Joint]:
        return next((j for j in self.joints if j.child is body and j.tree), None)

    def _ancestor(self, a: Body, b: Body) -> bool:
        """Whether ``a`` is ``b`` or one of its ancestors in the tree."""
        while b is not None:
            if b is a:
                return True
            j = self._parent_joint(b)
            b = j.parent if j is not None else None
        return False

    def _order(self) -> List[Body]:
        """The bodies, each after its parent (the tree's order)."""
        out, seen = [], set()

        def visit(b):
            if b.index in seen:
                return
            j = self._parent_joint(b)
            if j is not None and j.parent is not None:
                visit(j.parent)
            seen.add(b.index)
            out.append(b)
        for b in self.bodies:
            visit(b)
        return out

    # ------------------------------------------------------------------ coordinates
    @property
    def tree_joints(self) -> List[Joint]:
        return [j for j in self.joints if j.tree]

    def _coordinates(self) -> List[Tuple[str, bool]]:
        """The joint formulation's coordinates in the tree's order: ``(name, whether it starts a quaternion)``."""
        geo, out = self._geo, []
        for b in self._order():
            j = self._parent_joint(b)
            if j is None:
                prefix = self.free_names.get(b.name, b.name)
                out += [(f"{prefix}.{c}", False) for c in geo.axes]
                out += [(f"{prefix}.{c}", self.dim == 3 and k == 0) for k, c in enumerate(geo.ori_names)]
                continue
            for k, (kind, _, _) in enumerate(j.elements()):
                label = self._element_label(j, k)
                if kind == "spherical":
                    out += [(f"{label}.{c}", i == 0) for i, c in enumerate(Space.ori_names)]
                else:
                    out.append((label, False))
        return out

    @staticmethod
    def _element_label(j: Joint, k: int) -> str:
        """The name of a joint's element ``k``'s coordinate (a spherical one's quaternion's prefix)."""
        if j.part_names:
            return j.part_names[k]
        return j.name if len(j.elements()) == 1 else f"{j.name}.{k}"

    def joint_names(self) -> List[str]:
        """The joint formulation's coordinates, by name: one per revolute and prismatic tree joint (a compound
        joint's ``name.k`` per part), four (``name.qw`` … ``name.qz``) per spherical joint, the position and
        orientation of a free body (``name.x``, ``name.y``, ``name.theta`` in the plane; ``name.x`` … ``name.z``,
        ``name.qw`` … ``name.qz`` in space), in the tree's order."""
        return [n for n, _ in self._coordinates()]

    def _quaternions(self, labels: List[Tuple[str, bool]]) -> List[int]:
        return [i for i, (_, starts) in enumerate(labels) if starts]

    def _base(self, j: Joint, frames):
        if j.parent is None:
            return ca.DM.zeros(self.dim), ca.DM(self._geo.identity)
        return frames[j.parent.index]

    def _frames(self, qj) -> Dict[int, tuple]:
        """Each body's ``(origin, orientation)`` (its frame) from the joint coordinates ``qj`` (SX or DM),
        recursively: a joint's child starts at its zero pose in the parent and each elementary joint moves it."""
        geo, frames, k = self._geo, {}, 0
        d, no = self.dim, geo.nori
        for b in self._order():
            j = self._parent_joint(b)
            if j is None:
                frames[b.index] = (qj[k:k + d], qj[k + d:k + d + no])
                k += d + no
                continue
            po, pori = self._base(j, frames)
            ori = geo.compose(pori, ca.DM(j.rotation))
            o = po + ca.mtimes(geo.R(pori), ca.DM(j.parent_point)) - ca.mtimes(geo.R(ori), ca.DM(j.child_point))
            for e, (kind, axis, point) in enumerate(j.elements()):
                if kind == "prismatic":
                    o = o + (qj[k] - j.zero_of(e)) * ca.mtimes(geo.R(ori), ca.DM(axis))
                    k += 1
                    continue
                anchor = o + ca.mtimes(geo.R(ori), ca.DM(point))
                if kind == "revolute":
                    ori = geo.compose(ori, geo.hinge(axis, qj[k] - j.zero_of(e)))
                    k += 1
                else:
                    ori = geo.compose(ori, qj[k:k + 4])
                    k += 4
                o = anchor - ca.mtimes(geo.R(ori), ca.DM(point))
            frames[b.index] = (o, ori)
        return frames

    def _com(self, b: Body, origin, ori):
        return origin + ca.mtimes(self._geo.R(ori), ca.DM(b.com))

    def _maximal_frames(self, q) -> Dict[int, tuple]:
        """Each body's frame from its maximal coordinates (its centre of mass and orientation)."""
        d, no, frames = self.dim, self._geo.nori, {}
        for b in self.bodies:
            c, ori = q[(d + no) * b.index:(d + no) * b.index + d], q[(d + no) * b.index + d:(d + no) * (b.index + 1)]
            frames[b.index] = (c - ca.mtimes(self._geo.R(ori), ca.DM(b.com)), ori)
        return frames

    def _joint_coordinates(self, j: Joint, frames) -> List:
        """A simple tree joint's coordinates from the two bodies' frames (inverse kinematics): an angle, a
        displacement, a quaternion, or none."""
        geo = self._geo
        po, pori = self._base(j, frames)
        co, cori = frames[j.child.index]
        bori = geo.compose(pori, ca.DM(j.rotation))
        rel = geo.relative(bori, cori)
        if j.kind == "revolute":
            return [geo.hinge_angle(rel, j.axis) + j.zero]
        if j.kind == "spherical":
            return [rel[i] for i in range(4)]
        if j.kind == "prismatic":
            gap = co + ca.mtimes(geo.R(cori), ca.DM(j.child_point)) - po - \
                ca.mtimes(geo.R(pori), ca.DM(j.parent_point))
            return [ca.dot(ca.mtimes(geo.R(bori), ca.DM(j.axis)), gap) + j.zero]
        return []

    # ------------------------------------------------------------------ the system
    def system(self, formulation: str = "maximal", contact=None, limits: bool = False,
               restitution: float = 0.0, efforts: Optional[Dict[str, object]] = None) -> LagrangianSystem:
        """The :class:`LagrangianSystem` of the bodies and joints in ``formulation`` (module doc), with gravity,
        the joints' springs, dampers and armatures, and the bodies' outlines and joint points as its pictures
        (:attr:`links`).

        ``contact``: a function of a :class:`Frames` (``at``) that returns the system's
        :class:`~castrajectory.models.contact.Contact`, its gaps written with ``at(body, point)``, the world
        position of a body's point, and ``at.joint(name)``, a joint coordinate; ``at.limits()`` gives the joints'
        limits as gaps.  ``limits=True`` without ``contact``: the joints' limits alone, as contacts of
        ``restitution``.  ``efforts``: a torque (revolute) or a force (prismatic) on joint coordinates by name,
        numbers or expressions of the time and of controls (``ct.Control``): the generalised force ``τ ∇x`` of
        each coordinate ``x`` (its virtual work ``τ δx``), in either formulation.

        A rod on a pin whose angle is held within ±0.3 rad, its stop plastic:

        >>> import castrajectory as ct
        >>> mb = ct.Multibody(g=9.81)
        >>> rod = mb.body("rod", 1.0, 1.0 / 12)
        >>> _ = mb.revolute(mb.world, rod, child_point=(0.0, 0.5), name="pin", limits=(-0.3, 0.3))
        >>> limited = mb.system(limits=True)
        >>> limited.contact.names
        ['pin lower', 'pin upper']
        >>> run = ct.simulate(limited, *mb.state({"pin": 0.2}), T=1.0, N=40)
        >>> bool(run.success and max(abs(mb.joint_positions(q)[0]) for q in run.q) < 0.3 + 1e-9)
        True
        """
        if formulation not in FORMULATIONS:
            raise InputError(f"formulation must be one of {', '.join(FORMULATIONS)} (got {formulation!r})")
        if not self.bodies:
            raise InputError("a Multibody needs at least one body")
        q, names, frames, rows = self._unknowns(formulation)
        coords = dict(zip(names if formulation == "joint" else self.joint_names(),
                          self._coordinate_exprs(q, frames, formulation)))
        centres = [self._com(b, *frames[b.index]) for b in self.bodies]
        kinetic = _Bodies(centres, [frames[b.index][1] for b in self.bodies], self.bodies, self.dim,
                          q if formulation == "maximal" else None)
        potentials = []
        if np.any(self.gravity != 0):
            g = float(np.linalg.norm(self.gravity))
            up = -self.gravity / g
            potentials.append(Gravity(g, heights=[ca.dot(ca.DM(up), c) for c in centres],
                                      masses=[b.mass for b in self.bodies]))
        potentials += self._joint_terms(q, coords, kinetic, efforts)
        at = Frames(self, frames, coords)
        return LagrangianSystem(q, kinetic, potentials, constraints=rows, names=names,
                                points_expr=self._picture(frames),
                                contact=self._contact(at, contact, limits, restitution))

    def _unknowns(self, formulation: str):
        """``(q, names, frames, rows)`` of ``formulation``: the coordinates, their names, the bodies' frames as
        expressions of them, and the holonomic rows (maximal: every joint and each quaternion's norm; joint: the
        loop-closing joints and each quaternion coordinate's norm)."""
        geo, d, no = self._geo, self.dim, self._geo.nori
        if formulation == "maximal":
            compound = [j.name for j in self.joints if j.compound]
            if compound:
                raise InputError(f"joint {compound[0]} is a compound joint: its system is in joint coordinates "
                                 f"(system('joint'))")
            q = ca.SX.sym("q", (d + no) * len(self.bodies))
            names = [f"{b.name}.{c}" for b in self.bodies for c in geo.axes + geo.ori_names]
            frames = self._maximal_frames(q)
            rows = [r for j in self.joints for r in self._joint_rows(j, frames)]
            if d == 3:
                rows += [unit_norm(frames[b.index][1]) for b in self.bodies]
            return q, names, frames, rows
        labels = self._coordinates()
        names = [n for n, _ in labels]
        q = ca.SX.sym("q", len(names))
        frames = self._frames(q)
        rows = [r for j in self.joints if not j.tree for r in self._joint_rows(j, frames)]
        rows += [unit_norm(q[i:i + 4]) for i in self._quaternions(labels)]
        return q, names, frames, rows

    def _joint_terms(self, q, coords, kinetic, efforts) -> List:
        """The joints' springs, dampers and efforts as terms, each through its coordinate's expression ``coords``
        (so alike in both formulations); the armatures go into ``kinetic``."""
        kinetic_extra, spring, rayleigh = ca.SX(0), ca.SX(0), ca.SX(0)
        qd = velocity(q)
        used, terms = set(), []
        for j in self.tree_joints:
            for k, opts in j.options():
                x = coords[self._element_label(j, k)]
                rate = ca.jtimes(x, q, qd)
                kinetic_extra += 0.5 * opts.get("armature", 0.0) * rate * rate
                spring += 0.5 * opts.get("stiffness", 0.0) * (x - opts.get("rest", 0.0)) ** 2
                rayleigh += 0.5 * opts.get("damping", 0.0) * rate * rate
                used |= {key for key in ("armature", "stiffness", "damping") if opts.get(key)}
        if "stiffness" in used:
            terms.append(Potential(spring, "joint springs"))
        if "damping" in used:
            terms.append(Dissipation(rayleigh, "joint damping"))
        if "armature" in used:
            kinetic.extra = kinetic_extra
        if efforts:
            unknown = sorted(set(efforts) - set(coords))
            if unknown:
                raise InputError(f"efforts: unknown joint coordinates {', '.join(unknown)} (they are "
                                 f"{', '.join(coords)})")
            Q = ca.SX.zeros(q.numel())
            for name, tau in efforts.items():
                Q += ca.SX(tau) * ca.gradient(coords[name], q)
            terms.append(Force(Q, "joint efforts"))
        return terms

    @staticmethod
    def _contact(at, contact, limits: bool, restitution: float):
        """The system's contact: the user's (a function of ``at``), or the joints' limits, or none."""
        if contact is not None:
            if not callable(contact):
                raise InputError("contact must be a function of the bodies' frames (at) returning a ct.Contact")
            return contact(at)
        if not limits:
            return None
        from .contact import Contact
        gaps, gap_names = at.limits()
        if not gaps:
            raise InputError("limits=True: no joint has limits")
        return Contact(gaps, restitution=restitution, names=gap_names)

    def _coordinate_exprs(self, q, frames, formulation: str) -> List:
        """The joint coordinates (:meth:`joint_names`' order) as expressions of a system's ``q``: ``q`` itself in
        the joint formulation, the inverse kinematics of the bodies' frames in the maximal one."""
        if formulation == "joint":
            return [q[i] for i in range(q.numel())]
        out = []
        for b in self._order():
            j = self._parent_joint(b)
            if j is None:
                out += [frames[b.index][0][i] for i in range(self.dim)]
                out += [frames[b.index][1][i] for i in range(self._geo.nori)]
            elif j.compound:
                raise InputError(f"joint {j.name} is a compound joint: it has no maximal configuration")
            else:
                out += self._joint_coordinates(j, frames)
        return out

    def _joint_rows(self, j: Joint, frames) -> List:
        """The holonomic constraints of a simple joint ``j`` on the bodies' frames: its points coincide (a
        prismatic joint's across its axis only), and the orientations agree (all but the axis for a revolute joint
        in space; none for a spherical one)."""
        geo = self._geo
        po, pori = self._base(j, frames)
        co, cori = frames[j.child.index]
        gap = co + ca.mtimes(geo.R(cori), ca.DM(j.child_point)) - po - ca.mtimes(geo.R(pori), ca.DM(j.parent_point))
        bori = geo.compose(pori, ca.DM(j.rotation))
        rel = geo.relative(bori, cori)
        points = [gap[i] for i in range(self.dim)]
        if j.kind == "revolute":
            return points + geo.axis_rows(rel, j.axis)
        if j.kind == "spherical":
            return points
        if j.kind == "prismatic":
            across = [ca.dot(ca.mtimes(geo.R(bori), ca.DM(n)), gap) for n in geo.normals(j.axis)]
            return across + geo.weld_rows(rel)
        return points + geo.weld_rows(rel)

    def _picture_points(self) -> List[Tuple[Body, List[Tuple[float, ...]]]]:
        """Each body's points drawn, in its frame: its joints' points, then its outline (its centre of mass alone
        where it has neither)."""
        out = []
        for b in self.bodies:
            local = [j.child_point for j in self.joints if j.child is b] + \
                    [j.parent_point for j in self.joints if j.parent is b] + list(b.outline)
            out.append((b, local or [b.com]))
        return out

    @property
    def links(self) -> List[Tuple[int, int]]:
        """The pictures' segments, pairs of indices of the system's points: each body's points joined in order (a
        system file's ``links``)."""
        pairs, start = [], 0
        for _, local in self._picture_points():
            pairs += [(i, i + 1) for i in range(start, start + len(local) - 1)]
            start += len(local)
        return pairs

    def _picture(self, frames) -> List:
        """The points drawn (:meth:`_picture_points`), in the world (:attr:`links` joins them)."""
        R = self._geo.R
        return [frames[b.index][0] + ca.mtimes(R(frames[b.index][1]), ca.DM(p))
                for b, local in self._picture_points() for p in local]

    # ------------------------------------------------------------------ states
    def state(self, positions=None, rates=None, formulation: str = "maximal") -> Tuple[np.ndarray, np.ndarray]:
        """``(q0, q̇0)`` of ``formulation`` from the joint coordinates ``positions`` and their ``rates`` (sequences
        in :meth:`joint_names`' order, or dicts by name; zeros by default, and the identity for a quaternion): the
        maximal state is the tree's kinematics of them, consistent with every tree joint.  A quaternion's rate is
        ``ct.quaternion_rate(quaternion, ω)`` of the body's angular velocity ``ω`` in its own axes.  A
        loop-closing joint must hold too: refused otherwise."""
        labels = self._coordinates()
        names = [n for n, _ in labels]
        start = np.zeros(len(names))
        for i in self._quaternions(labels):
            start[i] = 1.0
        start = np.array([self.defaults.get(n, v) for n, v in zip(names, start)])
        qj = self._joint_vector(positions, names, "positions", start)
        vj = self._joint_vector(rates, names, "rates", np.zeros(len(names)))
        if formulation not in FORMULATIONS:
            raise InputError(f"formulation must be one of {', '.join(FORMULATIONS)} (got {formulation!r})")
        for i in self._quaternions(labels):
            if abs(np.linalg.norm(qj[i:i + 4]) - 1.0) > 1e-9:
                raise InputError(f"positions: the quaternion {names[i].rsplit('.', 1)[0]} is not a unit quaternion "
                                 f"(norm {np.linalg.norm(qj[i:i + 4]):.6g})")
        if formulation == "joint":
            out = (qj, vj)
        else:
            s = ca.SX.sym("s", len(names))
            frames = self._frames(s)
            qm = ca.vertcat(*[ca.vertcat(self._com(b, *frames[b.index]), frames[b.index][1]) for b in self.bodies])
            f = ca.Function("fk", [s], [qm, ca.jacobian(qm, s)])
            qv, Jv = f(qj)
            out = (np.asarray(qv, float).reshape(-1), np.asarray(Jv, float) @ vj)
        system = self.system(formulation)
        if system.nc:
            c = np.asarray(system.constraint(out[0], 0.0)[0]).reshape(-1)
            if np.max(np.abs(c)) > 1e-9:
                raise InputError(f"the joint positions do not close the loops (constraint violated by "
                                 f"{np.max(np.abs(c)):.3g}): give positions that do")
        return out

    def _joint_vector(self, values, names, what, default) -> np.ndarray:
        if values is None:
            return default
        if isinstance(values, dict):
            unknown = sorted(set(values) - set(names))
            if unknown:
                raise InputError(f"{what}: unknown joint coordinates {', '.join(unknown)} (they are "
                                 f"{', '.join(names)})")
            return np.array([float(values.get(n, v)) for n, v in zip(names, default)])
        v = np.asarray(values, float).reshape(-1)
        if v.size != len(names) or not np.all(np.isfinite(v)):
            raise InputError(f"{what}: {len(names)} finite values are needed ({', '.join(names)}), got {v.size}")
        return v

    def joint_positions(self, q) -> np.ndarray:
        """The joint coordinates of a maximal configuration ``q`` (each tree joint's angle, displacement or
        quaternion, a free body's pose), in :meth:`joint_names`' order.  An angle in the plane is the difference
        of the bodies' angles, unwrapped; in space it is read from the relative quaternion, in (−2π, 2π]."""
        d, no = self.dim, self._geo.nori
        q = np.asarray(q, float).reshape(-1)
        if q.size != (d + no) * len(self.bodies):
            raise InputError(f"a maximal configuration has {(d + no) * len(self.bodies)} entries (got {q.size})")
        key = (len(self.bodies), len(self.joints))          # (rebuilt when a body or a joint is added)
        if getattr(self, "_inverse", (None,))[0] != key:
            s = ca.SX.sym("s", q.size)
            out = self._coordinate_exprs(s, self._maximal_frames(s), "maximal")
            self._inverse = (key, ca.Function("ik", [s], [ca.vertcat(*out)]))
        return np.asarray(self._inverse[1](q), float).reshape(-1)

    def joint_coordinate(self, name: str, q, formulation: str = "maximal"):
        """The joint coordinate ``name`` as an expression of the system's coordinates ``q`` (SX) in
        ``formulation``: for contact gaps on a joint's range, or a quantity to report."""
        names = self.joint_names()
        if name not in names:
            raise InputError(f"unknown joint coordinate {name!r} (they are {', '.join(names)})")
        if formulation not in FORMULATIONS:
            raise InputError(f"formulation must be one of {', '.join(FORMULATIONS)} (got {formulation!r})")
        frames = self._maximal_frames(q) if formulation == "maximal" else None
        return self._coordinate_exprs(q, frames, formulation)[names.index(name)]


class Frames:
    """The bodies' frames of one system (the ``at`` of :meth:`Multibody.system`'s ``contact``): ``at(body,
    point)`` is the world position of ``point`` (the body's frame) of ``body`` (a :class:`Body` or its name), an
    expression of the system's coordinates; ``at.joint(name)`` a joint coordinate; ``at.limits()`` the joints'
    limits as gaps ``(gaps, names)``."""

    def __init__(self, mb: "Multibody", frames, coords):
        self._mb, self._frames, self._coords = mb, frames, coords

    def __call__(self, body, point=None):
        mb = self._mb
        b = next((x for x in mb.bodies if x is body or x.name == body), None)
        if b is None:
            raise InputError(f"no body {body!r} (the bodies are {', '.join(x.name for x in mb.bodies)})")
        p = checked_vector(np.zeros(mb.dim) if point is None else point, mb.dim, f"point of {b.name}")
        o, ori = self._frames[b.index]
        return o + ca.mtimes(mb._geo.R(ori), ca.DM(p))

    def joint(self, name: str):
        if name not in self._coords:
            raise InputError(f"unknown joint coordinate {name!r} (they are {', '.join(self._coords)})")
        return self._coords[name]

    def limits(self):
        gaps, names = [], []
        for j in self._mb.tree_joints:
            for k, opts in j.options():
                if opts.get("limits"):
                    label = self._mb._element_label(j, k)
                    lo, hi = opts["limits"]
                    gaps += [self._coords[label] - lo, hi - self._coords[label]]
                    names += [f"{label} lower", f"{label} upper"]
        return gaps, names


@dataclass
class _Bodies:
    """The kinetic energy of rigid bodies, ``Σ ½ m |ċ|² + ½ I θ̇²`` in the plane and ``Σ ½ m |ċ|² +
    ½ tr(Ṙ S Ṙᵀ)`` in space (``c`` the centres of mass, ``θ`` or ``R`` the orientations, expressions of q; ``S``
    the second moment); with ``q`` given (the maximal formulation, where they are q's own entries) the plane's
    Hessian is the constant ``diag(m, m, I)`` per body, written so.  ``extra``: a kinetic energy added (the
    joints' armatures)."""

    centres: list
    orientations: list
    bodies: list
    dim: int
    q: Optional[object] = None
    extra: object = 0

    def energy(self, q, qd):
        K = ca.SX(self.extra)
        if self.q is not None and self.dim == 2:
            w = np.concatenate([[b.mass, b.mass, b.inertia] for b in self.bodies])
            return K + 0.5 * ca.dot(ca.DM(w) * qd, qd)
        for c, ori, b in zip(self.centres, self.orientations, self.bodies):
            v = ca.jtimes(c, q, qd)
            K += 0.5 * b.mass * ca.dot(v, v)
            if self.dim == 2:
                w = ca.jtimes(ori, q, qd)
                K += 0.5 * b.inertia * w * w
                continue
            Rdot = ca.reshape(ca.jtimes(ca.vec(rotation(ori)), q, qd), 3, 3)
            K += 0.5 * ca.trace(ca.mtimes(ca.mtimes(Rdot, ca.DM(b.second_moment)), Rdot.T))
        return K
