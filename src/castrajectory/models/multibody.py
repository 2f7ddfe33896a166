"""Multibody systems from bodies and joints (issue 45): a planar builder whose systems come in two formulations of the
same physics.

* ``"maximal"`` (the default): every body its own coordinates ``(x, y, θ)`` of its centre of mass, so that its mass
  matrix is the constant ``diag(m, m, I)``, and every joint a few holonomic constraints between the two bodies it
  joins.  A system's unknowns, rows and their derivatives grow linearly with the bodies: each row touches two bodies.
* ``"joint"``: a tree's joint coordinates (an angle per revolute joint, a displacement per prismatic one, the pose of
  a free body), the bodies' positions and angles built by recursive kinematics.  Its mass matrix is dense, with
  entries along the whole path from the root, so its rows and their derivatives grow as the square of the bodies and
  worse.  It is kept for comparison, and it is what a chain written by hand in its angles is.

Joints (planar): ``revolute`` (a point of the parent and a point of the child coincide), ``prismatic`` (the child
slides along an axis of the parent without turning), ``weld`` (fixed), and none (a free body).  The parent may be
:attr:`Multibody.world` (the fixed base).  A joint whose child already has a parent closes a loop: it is a constraint
in both formulations.

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

import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import casadi as ca
import numpy as np

from ..validation import InputError, finite, positive
from .mechanics import Gravity, LagrangianSystem

#: the formulations of :meth:`Multibody.system`
FORMULATIONS = ("maximal", "joint")
#: the planar joint kinds and the coordinates each gives the joint formulation
JOINT_KINDS = {"revolute": 1, "prismatic": 1, "weld": 0}


def _rot(th):
    c, s = ca.cos(th), ca.sin(th)
    return ca.vertcat(ca.horzcat(c, -s), ca.horzcat(s, c))


def _point(value, what: str) -> Tuple[float, float]:
    try:
        v = np.asarray(value, float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be 2 numbers (got {value!r})") from None
    if v.size != 2 or not np.all(np.isfinite(v)):
        raise InputError(f"{what} must be 2 finite numbers (got {value!r})")
    return float(v[0]), float(v[1])


@dataclass(frozen=True)
class Body:
    """A planar rigid body: its ``mass``, its moment of ``inertia`` about its centre of mass, the centre of mass
    ``com`` in the body's frame, and ``outline``, body-frame points drawn joined in order (its pictures)."""

    name: str
    mass: float
    inertia: float
    com: Tuple[float, float] = (0.0, 0.0)
    outline: Tuple[Tuple[float, float], ...] = ()
    index: int = -1


@dataclass(frozen=True)
class Joint:
    """A planar joint of ``kind`` between ``parent`` (None: the world) and ``child``, at ``parent_point`` (the
    parent's frame; the world's for the base) and ``child_point`` (the child's frame); ``axis`` the prismatic
    joint's direction in the parent's frame; ``tree``: False where it closes a loop (its child had a parent)."""

    name: str
    kind: str
    parent: Optional[Body]
    child: Body
    parent_point: Tuple[float, float]
    child_point: Tuple[float, float]
    axis: Tuple[float, float] = (1.0, 0.0)
    tree: bool = True


@dataclass
class Multibody:
    """Planar bodies joined by joints (module doc); :meth:`system` the :class:`LagrangianSystem`, :meth:`state` an
    initial state from joint coordinates, :meth:`joint_positions` the joint coordinates of a maximal state.

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
    """

    g: float = 9.81
    bodies: List[Body] = field(default_factory=list)
    joints: List[Joint] = field(default_factory=list)

    #: the fixed base, a parent for the joints that hold a body to the world
    world = None

    def __post_init__(self):
        self.g = finite("g", self.g)

    # ------------------------------------------------------------------ building
    def body(self, name: str, mass: float, inertia: float, com=(0.0, 0.0), outline: Sequence = ()) -> Body:
        """A new body (a unique ``name``; ``mass`` and ``inertia`` about its centre of mass positive)."""
        name = str(name)
        if any(b.name == name for b in self.bodies):
            raise InputError(f"a body named {name!r} exists already")
        b = Body(name, positive(f"mass of {name}", mass), positive(f"inertia of {name}", inertia),
                 _point(com, f"com of {name}"), tuple(_point(p, f"outline point of {name}") for p in outline),
                 len(self.bodies))
        self.bodies.append(b)
        return b

    def revolute(self, parent: Optional[Body], child: Body, parent_point=(0.0, 0.0), child_point=(0.0, 0.0),
                 name: Optional[str] = None) -> Joint:
        """A pin: ``parent_point`` of the parent and ``child_point`` of the child coincide; its coordinate is the
        child's angle relative to the parent (0 where their frames are parallel)."""
        return self._joint("revolute", parent, child, parent_point, child_point, (1.0, 0.0), name)

    def prismatic(self, parent: Optional[Body], child: Body, axis=(1.0, 0.0), parent_point=(0.0, 0.0),
                  child_point=(0.0, 0.0), name: Optional[str] = None) -> Joint:
        """A slider: the child keeps the parent's orientation and its ``child_point`` moves along ``axis`` (the
        parent's frame) through ``parent_point``; its coordinate is the displacement along the unit axis."""
        a = np.asarray(_point(axis, "prismatic axis"))
        if not np.linalg.norm(a) > 0:
            raise InputError("the prismatic axis must be nonzero")
        a = a / np.linalg.norm(a)
        return self._joint("prismatic", parent, child, parent_point, child_point, (float(a[0]), float(a[1])), name)

    def weld(self, parent: Optional[Body], child: Body, parent_point=(0.0, 0.0), child_point=(0.0, 0.0),
             name: Optional[str] = None) -> Joint:
        """A fixed joint: the points coincide and the frames stay parallel."""
        return self._joint("weld", parent, child, parent_point, child_point, (1.0, 0.0), name)

    def _joint(self, kind, parent, child, pp, cp, axis, name) -> Joint:
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
        tree = not any(j.child is child and j.tree for j in self.joints)
        if tree and parent is not None and self._ancestor(child, parent):
            tree = False          # (it would make the child its own ancestor: a loop)
        j = Joint(name, kind, parent, child, _point(pp, f"parent point of {name}"),
                  _point(cp, f"child point of {name}"), axis, tree)
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

    def joint_names(self) -> List[str]:
        """The joint formulation's coordinates, by name: one per revolute and prismatic tree joint, three
        (``x``, ``y``, ``theta``) per free body, in the tree's order."""
        names = []
        for b in self._order():
            j = self._parent_joint(b)
            if j is None:
                names += [f"{b.name}.x", f"{b.name}.y", f"{b.name}.theta"]
            elif JOINT_KINDS[j.kind]:
                names.append(j.name)
        return names

    def _frames(self, qj) -> Dict[int, tuple]:
        """Each body's ``(origin, angle)`` (frame) from the joint coordinates ``qj`` (SX or DM), recursively."""
        frames, k = {}, 0
        for b in self._order():
            j = self._parent_joint(b)
            if j is None:
                frames[b.index] = (ca.vertcat(qj[k], qj[k + 1]), qj[k + 2])
                k += 3
                continue
            if j.parent is None:
                po, pth = ca.DM.zeros(2), 0.0
            else:
                po, pth = frames[j.parent.index]
            anchor = po + ca.mtimes(_rot(pth), ca.DM(j.parent_point))
            th = pth
            if j.kind == "revolute":
                th = pth + qj[k]
                k += 1
            elif j.kind == "prismatic":
                anchor = anchor + qj[k] * ca.mtimes(_rot(pth), ca.DM(j.axis))
                k += 1
            frames[b.index] = (anchor - ca.mtimes(_rot(th), ca.DM(j.child_point)), th)
        return frames

    def _com(self, b: Body, origin, th):
        return origin + ca.mtimes(_rot(th), ca.DM(b.com))

    # ------------------------------------------------------------------ the system
    def system(self, formulation: str = "maximal") -> LagrangianSystem:
        """The :class:`LagrangianSystem` of the bodies and joints in ``formulation`` (module doc), with gravity
        along −y and the bodies' outlines and joint points as its pictures (:attr:`links`)."""
        if formulation not in FORMULATIONS:
            raise InputError(f"formulation must be one of {', '.join(FORMULATIONS)} (got {formulation!r})")
        if not self.bodies:
            raise InputError("a Multibody needs at least one body")
        if formulation == "maximal":
            q = ca.SX.sym("q", 3 * len(self.bodies))
            com = {b.index: q[3 * b.index:3 * b.index + 2] for b in self.bodies}
            th = {b.index: q[3 * b.index + 2] for b in self.bodies}
            origin = {i: com[i] - ca.mtimes(_rot(th[i]), ca.DM(self.bodies[i].com)) for i in com}
            rows = [r for j in self.joints for r in self._joint_rows(j, origin, th)]
            names = [f"{b.name}.{c}" for b in self.bodies for c in ("x", "y", "theta")]
            kinetic = _Bodies([com[b.index] for b in self.bodies], [th[b.index] for b in self.bodies], self.bodies, q)
        else:
            names = self.joint_names()
            q = ca.SX.sym("q", len(names))
            frames = self._frames(q)
            origin = {i: f[0] for i, f in frames.items()}
            th = {i: f[1] for i, f in frames.items()}
            com = {b.index: self._com(b, origin[b.index], th[b.index]) for b in self.bodies}
            rows = [r for j in self.joints if not j.tree for r in self._joint_rows(j, origin, th)]
            kinetic = _Bodies([com[b.index] for b in self.bodies], [th[b.index] for b in self.bodies], self.bodies)
        potentials = [Gravity(self.g, heights=[com[b.index][1] for b in self.bodies],
                              masses=[b.mass for b in self.bodies])] if self.g != 0 else []
        points = self._picture(origin, th)
        return LagrangianSystem(q, kinetic, potentials, constraints=rows, names=names, points_expr=points)

    def _joint_rows(self, j: Joint, origin, th) -> List:
        """The holonomic constraints of joint ``j`` on the bodies' frames."""
        if j.parent is None:
            po, pth = ca.DM.zeros(2), 0.0
        else:
            po, pth = origin[j.parent.index], th[j.parent.index]
        co, cth = origin[j.child.index], th[j.child.index]
        gap = co + ca.mtimes(_rot(cth), ca.DM(j.child_point)) - po - ca.mtimes(_rot(pth), ca.DM(j.parent_point))
        if j.kind == "revolute":
            return [gap[0], gap[1]]
        if j.kind == "prismatic":
            normal = ca.mtimes(_rot(pth), ca.DM([-j.axis[1], j.axis[0]]))
            return [ca.dot(normal, gap), cth - pth]
        return [gap[0], gap[1], cth - pth]

    def _picture_points(self) -> List[Tuple[Body, List[Tuple[float, float]]]]:
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

    def _picture(self, origin, th) -> List:
        """The points drawn (:meth:`_picture_points`), in the world (:attr:`links` joins them)."""
        return [origin[b.index] + ca.mtimes(_rot(th[b.index]), ca.DM(p))
                for b, local in self._picture_points() for p in local]

    # ------------------------------------------------------------------ states
    def state(self, positions=None, rates=None, formulation: str = "maximal") -> Tuple[np.ndarray, np.ndarray]:
        """``(q0, q̇0)`` of ``formulation`` from the joint coordinates ``positions`` and their ``rates`` (sequences
        in :meth:`joint_names`' order, or dicts by name; zeros by default): the maximal state is the tree's
        kinematics of them, consistent with every tree joint.  A loop-closing joint must hold too: refused
        otherwise."""
        names = self.joint_names()
        qj = self._joint_vector(positions, names, "positions")
        vj = self._joint_vector(rates, names, "rates")
        if formulation not in FORMULATIONS:
            raise InputError(f"formulation must be one of {', '.join(FORMULATIONS)} (got {formulation!r})")
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

    def _joint_vector(self, values, names, what) -> np.ndarray:
        if values is None:
            return np.zeros(len(names))
        if isinstance(values, dict):
            unknown = sorted(set(values) - set(names))
            if unknown:
                raise InputError(f"{what}: unknown joint coordinates {', '.join(unknown)} (they are "
                                 f"{', '.join(names)})")
            return np.array([float(values.get(n, 0.0)) for n in names])
        v = np.asarray(values, float).reshape(-1)
        if v.size != len(names) or not np.all(np.isfinite(v)):
            raise InputError(f"{what}: {len(names)} finite values are needed ({', '.join(names)}), got {v.size}")
        return v

    def joint_positions(self, q) -> np.ndarray:
        """The joint coordinates of a maximal configuration ``q`` (each tree joint's angle or displacement, a
        free body's pose), in :meth:`joint_names`' order."""
        q = np.asarray(q, float).reshape(-1)
        if q.size != 3 * len(self.bodies):
            raise InputError(f"a maximal configuration has {3 * len(self.bodies)} entries (got {q.size})")
        out = []
        for b in self._order():
            com, th = q[3 * b.index:3 * b.index + 2], q[3 * b.index + 2]
            o = com - _rotn(th) @ np.asarray(b.com)
            j = self._parent_joint(b)
            if j is None:
                out += [o[0], o[1], th]
                continue
            if j.parent is None:
                po, pth = np.zeros(2), 0.0
            else:
                pc, pth = q[3 * j.parent.index:3 * j.parent.index + 2], q[3 * j.parent.index + 2]
                po = pc - _rotn(pth) @ np.asarray(j.parent.com)
            if j.kind == "revolute":
                out.append(th - pth)
            elif j.kind == "prismatic":
                d = o + _rotn(th) @ np.asarray(j.child_point) - po - _rotn(pth) @ np.asarray(j.parent_point)
                out.append(float((_rotn(pth) @ np.asarray(j.axis)) @ d))
        return np.array(out)


def _rotn(th) -> np.ndarray:
    c, s = math.cos(th), math.sin(th)
    return np.array([[c, -s], [s, c]])


@dataclass
class _Bodies:
    """The kinetic energy of planar rigid bodies, ``Σ ½ m |ċ|² + ½ I θ̇²`` (``c`` the centres of mass, ``θ`` the
    angles, expressions of q); with ``q`` given (the maximal formulation, where they are q's own entries) its Hessian
    is the constant ``diag(m, m, I)`` per body, written so."""

    centres: list
    angles: list
    bodies: list
    q: Optional[object] = None

    def energy(self, q, qd):
        if self.q is not None:
            w = np.concatenate([[b.mass, b.mass, b.inertia] for b in self.bodies])
            return 0.5 * ca.dot(ca.DM(w) * qd, qd)
        K = ca.SX(0)
        for c, th, b in zip(self.centres, self.angles, self.bodies):
            v = ca.jtimes(c, q, qd)
            w = ca.jtimes(th, q, qd)
            K += 0.5 * b.mass * ca.dot(v, v) + 0.5 * b.inertia * w * w
        return K
