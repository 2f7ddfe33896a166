"""Model files as :class:`~castrajectory.models.multibody.Multibody` systems (issue 45): MJCF read by MuJoCo's own
compiler (the ``mjcf`` extra), URDF by ``yourdfpy`` (the ``urdf`` extra).  Never a parser of our own: the compiled
model's numbers (MuJoCo's ``body_pos``, ``body_quat``, principal inertias and their frames, joints' anchors and axes)
are what the builder receives, so that a loaded system is the file's physics as the file's own tools read it.

What is carried: bodies (mass, centre of mass, inertia in its frame), joints (hinge, slide, ball, free, and several
joints of one body as a :meth:`~castrajectory.models.multibody.Multibody.compound` joint), the joints' damping,
springs, armatures and ``ref`` (the coordinate's value at the zero pose), their ranges (the limits, as contact
gaps with :meth:`Multibody.system`'s ``limits=True``), gravity, and the geometry for the pictures (a capsule's or a cylinder's ends, another geom's centre).

What is refused, by name, before anything is built: what the builder cannot hold exactly (a joint's dry friction
``frictionloss``, damping, a spring or an armature on a ball joint, a ball joint's cone
limit, a moving body without mass, a URDF ``planar`` joint or a ``mimic``).  What is left out, silently, because it is
not the model's mechanics: actuators, sensors, contacts between geoms (the system's contacts are the user's gaps),
the world's own geometry and MuJoCo's solver settings.  Static bodies (no joint on the way to the world) become the
world; a massless body welded to its parent (a frame for sites) is folded into the parent.
"""
from __future__ import annotations

import os
from typing import Dict, Tuple

import numpy as np

from ..validation import InputError
from .multibody import Multibody
from .poses import matrix_quaternion
from .rigidbody import quat_multiply, rotation


def _compose(pose, pos, quat) -> Tuple[np.ndarray, np.ndarray]:
    """``pose ∘ (pos, quat)``: a frame given in ``pose``'s frame, in ``pose``'s parent."""
    p0, q0 = pose
    return p0 + rotation(q0) @ np.asarray(pos, float), quat_multiply(q0, np.asarray(quat, float))


def _need(module: str, extra: str):
    import importlib
    try:
        return importlib.import_module(module)
    except ImportError:
        raise InputError(f"loading this model file needs {module} (pip install \"castrajectory[{extra}]\")") from None


# ----------------------------------------------------------------------------- MJCF
def load_mjcf(source: str, g=None) -> Multibody:
    """The :class:`Multibody` of an MJCF model (a file path, or the XML text itself), compiled by MuJoCo; its joint
    coordinates are MuJoCo's ``qpos`` in order, by the joints' names (:meth:`Multibody.joint_names`).  ``g``
    replaces the file's gravity vector (a number: along −z).

    A thin cylinder of 1 kg and length 1 on a hinge at its end, from MJCF text (a path works the same): its joint
    system's mass is the moment about the pin, m l²/3 + m r²/4, as MuJoCo computes it from the geom:

    >>> import castrajectory as ct
    >>> pendulum = ct.load_mjcf('''<mujoco><worldbody><body name="rod">
    ...   <joint name="pin" type="hinge" axis="0 1 0"/>
    ...   <geom type="cylinder" fromto="0 0 0 0 0 -1" size="0.01" mass="1"/></body></worldbody></mujoco>''')
    >>> pendulum.joint_names(), round(float(pendulum.system("joint").mass_matrix([0.0])[0, 0]), 6)
    (['pin'], 0.333358)
    """
    mujoco = _need("mujoco", "mjcf")
    text = str(source)
    try:
        if text.lstrip().startswith("<"):
            model = mujoco.MjModel.from_xml_string(text)
        else:
            if not os.path.isfile(text):
                raise InputError(f"no model file {text!r}")
            model = mujoco.MjModel.from_xml_path(text)
    except ValueError as exc:          # MuJoCo's compiler error: one line
        raise InputError(f"MuJoCo could not load the model: {str(exc).strip().splitlines()[0]}") from None
    return _from_mujoco(model, mujoco, g)


def _body_name(model, mujoco, b: int) -> str:
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
    return name if name else f"body{b}"


def _joint_name(model, mujoco, j: int) -> str:
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
    return name if name else f"joint{j}"


def _from_mujoco(model, mujoco, g) -> Multibody:
    JT = mujoco.mjtJoint
    kinds = {int(JT.mjJNT_HINGE): "revolute", int(JT.mjJNT_SLIDE): "prismatic", int(JT.mjJNT_BALL): "spherical",
             int(JT.mjJNT_FREE): "free"}
    mb = Multibody(g=np.asarray(model.opt.gravity, float) if g is None else g, dim=3)
    # where each MuJoCo body is: (its castrajectory body or None for the world, its frame's pose in that body)
    where: Dict[int, tuple] = {0: (None, (np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])))}
    outlines: Dict[str, list] = {}
    for b in range(1, model.nbody):
        name = _body_name(model, mujoco, b)
        if model.body_mocapid[b] >= 0:
            raise InputError(f"body {name} is a mocap body (moved by the user, not by mechanics)")
        owner, pose = where[int(model.body_parentid[b])]
        pose = _compose(pose, model.body_pos[b], model.body_quat[b])
        first, count = int(model.body_jntadr[b]), int(model.body_jntnum[b])
        joints = list(range(first, first + count))
        mass = float(model.body_mass[b])
        if not joints and (owner is None or mass == 0.0):
            where[b] = (owner, pose)              # static, or a massless frame welded to its parent: folded in
            if owner is not None:
                outlines[owner.name] += _geom_points(model, mujoco, b, pose)
            continue
        if mass <= 0.0:
            raise InputError(f"body {name} moves and has no mass: give it a mass (or inertiafromgeom)")
        Ri = rotation(np.asarray(model.body_iquat[b], float))
        inertia = Ri @ np.diag(model.body_inertia[b]) @ Ri.T
        body = mb.body(name, mass, inertia, com=model.body_ipos[b])
        outlines[name] = _geom_points(model, mujoco, b, (np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])))
        where[b] = (body, (np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])))
        parent = owner
        if not joints:
            mb.weld(parent, body, parent_point=pose[0], rotation=pose[1], name=f"{name}.weld")
            continue
        parts, options = [], []
        for j in joints:
            jname = _joint_name(model, mujoco, j)
            kind = kinds[int(model.jnt_type[j])]
            dof, qadr = int(model.jnt_dofadr[j]), int(model.jnt_qposadr[j])
            if kind == "free":
                if count > 1 or parent is not None:
                    raise InputError(f"joint {jname}: a free joint is the only joint of a body of the world")
                opts = _free_options(model, j, dof, jname)
                parts = None
                continue
            n = 3 if kind == "spherical" else 1
            if np.any(model.dof_frictionloss[dof:dof + n] != 0):
                raise InputError(f"joint {jname} has dry friction (frictionloss), which castrajectory does not model")
            opts = {}
            if kind == "spherical":
                if np.any(model.dof_damping[dof:dof + 3] != 0) or model.jnt_stiffness[j] != 0 \
                        or np.any(model.dof_armature[dof:dof + 3] != 0):
                    raise InputError(f"joint {jname}: damping, a spring or an armature on a ball joint is not "
                                     f"carried")
                if model.jnt_limited[j]:
                    raise InputError(f"joint {jname}: a ball joint's cone limit is not carried")
            else:
                opts = {"damping": float(model.dof_damping[dof]), "stiffness": float(model.jnt_stiffness[j]),
                        "rest": float(model.qpos_spring[qadr]), "armature": float(model.dof_armature[dof]),
                        "zero": float(model.qpos0[qadr])}
                if model.jnt_limited[j]:
                    opts["limits"] = tuple(float(x) for x in model.jnt_range[j])
            axis = np.asarray(model.jnt_axis[j], float) if kind != "spherical" else None
            parts.append((kind, axis, np.asarray(model.jnt_pos[j], float), jname))
            options.append(opts)
        if parts is None:                         # a free body: its coordinates are MuJoCo's, world frame
            _rename_free(mb, body, _joint_name(model, mujoco, joints[0]))
            continue
        if len(parts) == 1:
            kind, axis, point, jname = parts[0]
            make = {"revolute": mb.revolute, "prismatic": mb.prismatic}.get(kind)
            anchor = pose[0] + rotation(pose[1]) @ point
            if make is not None:
                make(parent, body, parent_point=anchor, child_point=point, axis=axis, rotation=pose[1], name=jname,
                     **options[0])
            else:
                mb.spherical(parent, body, parent_point=anchor, child_point=point, rotation=pose[1], name=jname)
        else:
            mb.compound(parent, body, [(k, a, p, o) for (k, a, p, _), o in zip(parts, options)], position=pose[0],
                        rotation=pose[1], name=name, names=[p[3] for p in parts])
    for body in mb.bodies:
        object.__setattr__(body, "outline", tuple(tuple(float(x) for x in p) for p in outlines[body.name]))
    names = mb.joint_names()
    order = mujoco_order(mb, model)
    mb.defaults = {names[i]: float(model.qpos0[k]) for i, k in enumerate(order) if model.qpos0[k] != 0}
    return mb


def mujoco_order(mb: Multibody, model) -> np.ndarray:
    """For each of ``mb``'s joint coordinates (:meth:`Multibody.joint_names`), the index of MuJoCo's ``qpos`` entry
    that is the same coordinate (by the joints' names): ``qpos[order]`` is a castrajectory joint state."""
    import mujoco
    where = {}
    suffix = {int(mujoco.mjtJoint.mjJNT_FREE): ("x", "y", "z", "qw", "qx", "qy", "qz"),
              int(mujoco.mjtJoint.mjJNT_BALL): ("qw", "qx", "qy", "qz")}
    for j in range(model.njnt):
        name, adr = _joint_name(model, mujoco, j), int(model.jnt_qposadr[j])
        ends = suffix.get(int(model.jnt_type[j]))
        if ends is None:
            where[name] = adr
        else:
            where.update({f"{name}.{e}": adr + k for k, e in enumerate(ends)})
    missing = [n for n in mb.joint_names() if n not in where]
    if missing:
        raise InputError(f"coordinates {', '.join(missing)} are not the model's joints")
    return np.array([where[n] for n in mb.joint_names()])


def _free_options(model, j, dof, jname):
    if np.any(model.dof_damping[dof:dof + 6] != 0) or np.any(model.dof_armature[dof:dof + 6] != 0) \
            or np.any(model.dof_frictionloss[dof:dof + 6] != 0):
        raise InputError(f"joint {jname}: damping, an armature or dry friction on a free joint is not carried")
    return {}


def _rename_free(mb: Multibody, body, jname: str) -> None:
    """A free body's coordinates are named after its MuJoCo joint."""
    mb.free_names[body.name] = jname


def _geom_points(model, mujoco, b: int, pose) -> list:
    """Points of body ``b``'s geoms for the pictures, in the frame ``pose`` is relative to: a capsule's or a
    cylinder's two ends, another geom's centre."""
    GT = mujoco.mjtGeom
    out = []
    for k in range(int(model.body_geomadr[b]), int(model.body_geomadr[b]) + int(model.body_geomnum[b])):
        centre, quat = _compose(pose, model.geom_pos[k], model.geom_quat[k])
        if int(model.geom_type[k]) in (int(GT.mjGEOM_CAPSULE), int(GT.mjGEOM_CYLINDER)):
            half = rotation(quat) @ np.array([0.0, 0.0, float(model.geom_size[k][1])])
            out += [centre + half, centre - half]
        elif int(model.geom_type[k]) != int(GT.mjGEOM_PLANE):
            out.append(centre)
    return out


# ----------------------------------------------------------------------------- URDF
def _rpy(rpy) -> np.ndarray:
    """The quaternion of URDF's roll-pitch-yaw (fixed axes x, y, z: R = Rz(yaw) Ry(pitch) Rx(roll))."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    R = np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                  [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                  [-sp, cp * sr, cp * cr]])
    return matrix_quaternion(R)


def _pose(matrix) -> Tuple[np.ndarray, np.ndarray]:
    """A 4 × 4 homogeneous transform (yourdfpy's ``origin``) as (position, quaternion)."""
    T = np.eye(4) if matrix is None else np.asarray(matrix, float)
    return T[:3, 3].copy(), matrix_quaternion(T[:3, :3])


def load_urdf(source: str, g=9.81) -> Multibody:
    """The :class:`Multibody` of a URDF model (a file path, or the XML text itself), read by ``yourdfpy``; the root
    link is fixed to the world (as ROS and MuJoCo take it), a ``floating`` joint makes a free body.  Gravity ``g``
    along −z (a number) or a vector: URDF has none of its own.

    A point-like 2 kg bob 0.5 below a revolute joint about x:

    >>> import castrajectory as ct
    >>> bob = ct.load_urdf('''<robot name="p"><link name="base"/>
    ...   <link name="bob"><inertial><origin xyz="0 0 -0.5"/><mass value="2"/>
    ...     <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>
    ...   <joint name="pin" type="revolute"><parent link="base"/><child link="bob"/><axis xyz="1 0 0"/>
    ...     <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>''')
    >>> round(float(bob.system("joint").mass_matrix([0.0])[0, 0]), 6)     # 2 · 0.5² + 1e-4
    0.5001
    """
    yourdfpy = _need("yourdfpy", "urdf")
    text = str(source)
    try:
        if text.lstrip().startswith("<"):
            import io
            robot = yourdfpy.URDF.load(io.StringIO(text), load_meshes=False, build_scene_graph=False)
        else:
            if not os.path.isfile(text):
                raise InputError(f"no model file {text!r}")
            robot = yourdfpy.URDF.load(text, load_meshes=False, build_scene_graph=False)
    except InputError:
        raise
    except Exception as exc:            # yourdfpy's parse errors: one line
        raise InputError(f"yourdfpy could not read the URDF: {str(exc).strip().splitlines()[0]}") from None
    links = {link.name: link for link in robot.robot.links}
    joints = list(robot.robot.joints)
    children = {j.child for j in joints}
    roots = [name for name in links if name not in children]
    if len(roots) != 1:
        raise InputError(f"a URDF model has one root link (got {len(roots)}: {', '.join(roots)})")
    mb = Multibody(g=g, dim=3)
    where = {roots[0]: (None, (np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])))}
    pending = list(joints)
    while pending:
        ready = [j for j in pending if j.parent in where]
        if not ready:
            raise InputError(f"joints {', '.join(j.name for j in pending)} do not hang from the root link")
        for j in ready:
            pending.remove(j)
            _urdf_joint(mb, j, links[j.child], where)
    return mb


def _urdf_joint(mb: Multibody, j, link, where) -> None:
    owner, pose = where[j.parent]
    pose = _compose(pose, *_pose(j.origin))
    inertial = link.inertial
    mass = float(inertial.mass) if inertial is not None and inertial.mass is not None else 0.0
    if j.mimic is not None:
        raise InputError(f"joint {j.name} mimics another joint, which castrajectory does not carry")
    if j.type == "fixed" and (owner is None or mass == 0.0):
        where[link.name] = (owner, pose)
        return
    if mass <= 0.0:
        raise InputError(f"link {link.name} moves and has no mass (an <inertial> with a positive mass is needed)")
    ipos, iquat = _pose(inertial.origin)
    Ri = rotation(iquat)
    inertia = Ri @ np.asarray(inertial.inertia, float) @ Ri.T
    outline = []
    for visual in link.visuals or ():
        outline.append(_pose(visual.origin)[0])
    body = mb.body(link.name, mass, inertia, com=ipos, outline=outline)
    where[link.name] = (body, (np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])))
    opts = {}
    if j.dynamics is not None:
        if j.dynamics.friction:
            raise InputError(f"joint {j.name} has dry friction, which castrajectory does not model")
        opts["damping"] = float(j.dynamics.damping or 0.0)
    if j.type in ("revolute", "prismatic") and j.limit is not None and j.limit.lower is not None \
            and j.limit.upper is not None and j.limit.lower < j.limit.upper:
        opts["limits"] = (float(j.limit.lower), float(j.limit.upper))
    axis = np.asarray(j.axis if j.axis is not None else (1.0, 0.0, 0.0), float)
    if j.type in ("revolute", "continuous"):
        mb.revolute(owner, body, parent_point=pose[0], axis=axis, rotation=pose[1], name=j.name, **opts)
    elif j.type == "prismatic":
        mb.prismatic(owner, body, axis=axis, parent_point=pose[0], rotation=pose[1], name=j.name, **opts)
    elif j.type == "fixed":
        mb.weld(owner, body, parent_point=pose[0], rotation=pose[1], name=j.name)
    elif j.type == "floating":
        if owner is not None:
            raise InputError(f"joint {j.name}: a floating joint hangs from the root link (the world)")
        mb.free_names[body.name] = j.name
    else:
        raise InputError(f"joint {j.name} is a {j.type} joint, which castrajectory does not carry")
