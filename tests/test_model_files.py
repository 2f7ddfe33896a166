"""Model files as systems (issue 45): MJCF through MuJoCo's compiler, URDF through yourdfpy, checked against MuJoCo
itself: its joint-space mass matrix (``mj_fullM``), its energy, and a short rollout of its RK4 at a tiny step with
its constraints (limits, contacts) switched off, at random states.  A free or ball joint's velocity in MuJoCo is an
angular velocity (in the body's axes); castrajectory's coordinate is the quaternion, q̇ = ½ q ⊗ (0, ω), so the
comparison pulls castrajectory's mass matrix back through that map, Gᵀ M G."""
from __future__ import annotations

import glob
import os

import numpy as np
import pytest

import castrajectory as ct
from castrajectory.models.model_files import load_mjcf, load_urdf, mujoco_order
from castrajectory.validation import InputError

mujoco = pytest.importorskip("mujoco", reason="the MJCF loader and its oracle need mujoco (the mjcf extra)")

#: hinges about skew axes, a slide, a ball, a body with a hinge and a slide (a compound joint), a free body; damping,
#: a spring with its rest away from zero, an armature and a hinge with ref ≠ 0; inertias off their principal axes
MJCF = """<mujoco><option gravity="0 0 -9.81"/><worldbody>
<body name="a" pos="0 0 1" quat="0.9 0.1 0.2 0.3">
 <joint name="h1" type="hinge" axis="1 0.5 0" pos="0 0 0.1" damping="0.3" armature="0.05"/>
 <geom type="capsule" fromto="0 0 0 0 0 -1" size="0.05" mass="1.3"/>
 <body name="b" pos="0.1 0 -1" euler="10 20 30">
  <joint name="s1" type="slide" axis="0 1 1" stiffness="4" springref="0.2"/>
  <geom type="box" size="0.1 0.2 0.3" pos="0.05 0 0" mass="0.7"/>
  <body name="c" pos="0 0.2 -0.3"><joint name="b1" type="ball" pos="0 0 0.05"/>
   <geom type="ellipsoid" size="0.1 0.2 0.3" pos="0.05 0.1 -0.2" euler="5 10 15" mass="0.9"/>
   <body name="d" pos="0 0 -0.5">
    <joint name="h2" type="hinge" axis="0 1 0" ref="0.3"/><joint name="s2" type="slide" axis="1 0 0"/>
    <geom type="cylinder" fromto="0 0 0 0.3 0 -0.3" size="0.04" mass="0.4"/></body>
  </body></body></body>
<body name="free" pos="1 1 1"><freejoint name="f"/><geom type="box" size="0.1 0.15 0.2" mass="2"/></body>
</worldbody></mujoco>"""

#: a URDF arm: a revolute shoulder with a limit, a prismatic joint along a skew axis, a continuous wrist and a tool
#: welded on; origins with roll-pitch-yaw, inertias with products of inertia in rotated inertial frames
URDF = """<robot name="arm">
 <link name="base"/>
 <link name="l1"><inertial><origin xyz="0 0 -0.25" rpy="0.1 0.2 0.3"/><mass value="1.2"/>
   <inertia ixx="0.03" ixy="0.001" ixz="-0.002" iyy="0.025" iyz="0.003" izz="0.01"/></inertial>
   <visual><origin xyz="0 0 -0.25"/><geometry><cylinder radius="0.03" length="0.5"/></geometry></visual></link>
 <link name="l2"><inertial><origin xyz="0.05 0 -0.1"/><mass value="0.8"/>
   <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.012" iyz="0" izz="0.006"/></inertial></link>
 <link name="l3"><inertial><origin xyz="0 0.1 -0.2" rpy="0.3 0 0"/><mass value="0.6"/>
   <inertia ixx="0.008" ixy="0.0005" ixz="0" iyy="0.007" iyz="0" izz="0.004"/></inertial></link>
 <link name="tool"><inertial><origin xyz="0 0 -0.05"/><mass value="0.3"/>
   <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.0008"/></inertial></link>
 <joint name="shoulder" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0 1" rpy="0 0.2 0"/>
   <axis xyz="1 0 0"/><limit lower="-2" upper="2" effort="10" velocity="5"/></joint>
 <joint name="slide" type="prismatic"><parent link="l1"/><child link="l2"/><origin xyz="0 0 -0.5" rpy="0.1 0 0.4"/>
   <axis xyz="0 0.6 0.8"/><limit lower="-0.3" upper="0.3" effort="10" velocity="5"/></joint>
 <joint name="wrist" type="continuous"><parent link="l2"/><child link="l3"/><origin xyz="0.05 0 -0.2" rpy="0 0 0.5"/>
   <axis xyz="0 1 0"/></joint>
 <joint name="mount" type="fixed"><parent link="l3"/><child link="tool"/><origin xyz="0 0 -0.4" rpy="0.2 0 0"/></joint>
</robot>"""


def _random_state(model, rng):
    """A random ``qpos`` (hinges and slides in ±0.5 about their ref, random unit quaternions) and ``qvel``."""
    qpos = model.qpos0.copy()
    for j in range(model.njnt):
        a, kind = int(model.jnt_qposadr[j]), int(model.jnt_type[j])
        if kind in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            qpos[a] += rng.uniform(-0.5, 0.5)
            continue
        if kind == int(mujoco.mjtJoint.mjJNT_FREE):
            qpos[a:a + 3] = rng.normal(size=3)
            a += 3
        w = rng.normal(size=4)
        qpos[a:a + 4] = w / np.linalg.norm(w)
    return qpos, rng.normal(size=model.nv)


def _velocity_map(model, qpos, order):
    """G with castrajectory's joint rates q̇ = G · MuJoCo's qvel."""
    where = {int(k): i for i, k in enumerate(order)}
    G = np.zeros((len(order), model.nv))
    for j in range(model.njnt):
        a, dof, kind = int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j]), int(model.jnt_type[j])
        if kind in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            G[where[a], dof] = 1.0
            continue
        if kind == int(mujoco.mjtJoint.mjJNT_FREE):
            for k in range(3):
                G[where[a + k], dof + k] = 1.0
            a, dof = a + 3, dof + 3
        for k in range(3):
            rate = ct.quaternion_rate(qpos[a:a + 4], np.eye(3)[k])
            for i in range(4):
                G[where[a + i], dof + k] = rate[i]
    return G


def _mujoco_at(model, qpos, qvel):
    data = mujoco.MjData(model)
    model.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    data.qpos[:], data.qvel[:] = qpos, qvel
    mujoco.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return data, M


def _reduced(mb, system, qj, vj_columns):
    """The maximal system's mass matrix pulled back to joint velocities: Jᵀ M J, J's columns the maximal rates of
    each joint velocity (exact: the kinematics' Jacobian)."""
    q, _ = mb.state(qj)
    J = np.column_stack([mb.state(qj, col)[1] for col in vj_columns.T])
    return J.T @ np.asarray(system.mass_matrix(q)) @ J


def test_an_mjcf_model_has_mujocos_mass_matrix_and_energy():
    """Every joint kind, springs, an armature and a ref: Gᵀ M G equals mj_fullM (measured 5e-15 of entries up to
    5.8) and the energy equals MuJoCo's kinetic plus potential (7e-15), at three random states."""
    mb = load_mjcf(MJCF)
    model = mujoco.MjModel.from_xml_string(MJCF)
    order = mujoco_order(mb, model)
    assert mb.joint_names() == ["h1", "s1", "b1.qw", "b1.qx", "b1.qy", "b1.qz", "h2", "s2", "f.x", "f.y", "f.z",
                                "f.qw", "f.qx", "f.qy", "f.qz"]
    system = mb.system("joint")
    rng = np.random.default_rng(3)
    for _ in range(3):
        qpos, qvel = _random_state(model, rng)
        data, M = _mujoco_at(model, qpos, qvel)
        G = _velocity_map(model, qpos, order)
        assert np.max(np.abs(G.T @ np.asarray(system.mass_matrix(qpos[order])) @ G - M)) < 1e-12
        assert float(system.energy(qpos[order], G @ qvel)) == pytest.approx(float(np.sum(data.energy)), abs=1e-12)
    # the model's qpos0 (h2's ref, the free body's pose) is where state() starts
    q0, _ = mb.state(formulation="joint")
    assert np.array_equal(q0, model.qpos0[order])


def test_the_models_pictures_are_mujocos_geoms():
    """A capsule's and a cylinder's ends, and the boxes' and the ellipsoid's centres, are among the system's
    points, where MuJoCo puts them (to rounding) at a random state."""
    mb = load_mjcf(MJCF)
    model = mujoco.MjModel.from_xml_string(MJCF)
    qpos, qvel = _random_state(model, np.random.default_rng(4))
    data, _ = _mujoco_at(model, qpos, qvel)
    points = np.asarray(mb.system("joint").points(qpos[mujoco_order(mb, model)]))
    expected = []
    for k in range(model.ngeom):
        if int(model.geom_type[k]) in (int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_CYLINDER)):
            half = data.geom_xmat[k].reshape(3, 3) @ np.array([0.0, 0.0, model.geom_size[k][1]])
            expected += [data.geom_xpos[k] + half, data.geom_xpos[k] - half]
        else:
            expected.append(data.geom_xpos[k])
    assert len(expected) == 7
    for p in expected:
        assert np.min(np.linalg.norm(points - p, axis=1)) < 1e-12


def test_an_mjcf_models_free_motion_is_mujocos_rk4():
    """From a random state, 0.3 s of the joint system (galerkin6, N = 30) against MuJoCo's RK4 at a 1e-4 s step
    (it moves by 3.3e-13 when the step is halved): the coordinates agree to 6.5e-12 (measured) with damping, a
    spring, an armature, a ball joint, a compound joint and a free body."""
    mb = load_mjcf(MJCF)
    model = mujoco.MjModel.from_xml_string(MJCF)
    order = mujoco_order(mb, model)
    qpos, qvel = _random_state(model, np.random.default_rng(5))
    data, _ = _mujoco_at(model, qpos, qvel)
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    model.opt.integrator, model.opt.timestep = int(mujoco.mjtIntegrator.mjINT_RK4), 1e-4
    for _ in range(3000):
        mujoco.mj_step(model, data)
    G = _velocity_map(model, qpos, order)
    run = ct.simulate(mb.system("joint"), qpos[order], G @ qvel, T=0.3, N=30, scheme="galerkin6")
    assert run.success, run.message
    assert np.max(np.abs(run.q[-1] - data.qpos[order])) < 3e-10


@pytest.mark.parametrize("formulation", ["joint", "maximal"])
def test_a_urdf_model_is_mujocos_arm(formulation):
    """The URDF arm read by yourdfpy and by MuJoCo's own URDF import: the same mass matrix (in maximal coordinates
    pulled back through the kinematics, Jᵀ M J; measured 9e-16 and 2e-15), the same energy, and 0.5 s of free
    motion (galerkin6, N = 40) within 1.5e-12 (joint) and 1.6e-14 (maximal) of MuJoCo's RK4 at a 1e-4 s step."""
    pytest.importorskip("yourdfpy", reason="the URDF loader needs yourdfpy (the urdf extra)")
    mb = load_urdf(URDF)
    assert [b.name for b in mb.bodies] == ["l1", "l2", "l3", "tool"]
    model = mujoco.MjModel.from_xml_string(URDF)
    order = mujoco_order(mb, model)
    system = mb.system(formulation)
    qpos, qvel = _random_state(model, np.random.default_rng(6))
    data, M = _mujoco_at(model, qpos, qvel)
    P = _velocity_map(model, qpos, order)
    if formulation == "joint":
        M_ours = P.T @ np.asarray(system.mass_matrix(qpos[order])) @ P
    else:
        M_ours = _reduced(mb, system, qpos[order], P)
    assert np.max(np.abs(M_ours - M)) < 1e-12
    q0, v0 = mb.state(qpos[order], P @ qvel, formulation=formulation)
    assert float(system.energy(q0, v0)) == pytest.approx(float(np.sum(data.energy)), abs=1e-12)
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    model.opt.integrator, model.opt.timestep = int(mujoco.mjtIntegrator.mjINT_RK4), 1e-4
    for _ in range(5000):
        mujoco.mj_step(model, data)
    run = ct.simulate(system, q0, v0, T=0.5, N=40, scheme="galerkin6")
    assert run.success, run.message
    end = run.q[-1] if formulation == "joint" else mb.joint_positions(run.q[-1])
    assert np.max(np.abs(end - data.qpos[order])) < (1e-10 if formulation == "joint" else 1e-12)


def _gymnasium_models():
    try:
        import gymnasium
    except ImportError:
        return []
    return sorted(glob.glob(os.path.join(os.path.dirname(gymnasium.__file__), "envs", "mujoco", "assets", "*.xml")))


@pytest.mark.skipif(not _gymnasium_models(), reason="gymnasium (its MuJoCo model files) is not installed")
@pytest.mark.parametrize("path", _gymnasium_models(), ids=os.path.basename)
def test_gymnasiums_models_load_with_mujocos_mass_matrix(path):
    """Models that ship with gymnasium (ant, hopper, humanoid, walker, ...): loaded in one call, their joint system's
    mass matrix is MuJoCo's at a random state (measured at most 2e-14 over the 14 files)."""
    mb = load_mjcf(path)
    model = mujoco.MjModel.from_xml_path(path)
    order = mujoco_order(mb, model)
    qpos, qvel = _random_state(model, np.random.default_rng(7))
    _, M = _mujoco_at(model, qpos, qvel)
    G = _velocity_map(model, qpos, order)
    M_ours = G.T @ np.asarray(mb.system("joint").mass_matrix(qpos[order])) @ G
    assert np.max(np.abs(M_ours - M)) < 1e-12 * max(1.0, np.max(np.abs(M)))


@pytest.mark.parametrize("restitution", [0.0, 1.0])
def test_a_joint_range_is_a_contact_gap(restitution):
    """A weightless rod turning at 2 rad/s about a hinge whose range is (−0.5, 0.3), from 0.2: it reaches the stop
    at t = 0.05 exactly and stays there (plastic) or turns back at −2 rad/s (elastic)."""
    xml = """<mujoco><compiler angle="radian"/><option gravity="0 0 0"/><worldbody><body name="rod">
      <joint name="pin" type="hinge" axis="0 1 0" range="-0.5 0.3" limited="true"/>
      <geom type="capsule" fromto="0 0 0 0 0 -1" size="0.05" mass="1"/></body></worldbody></mujoco>"""
    mb = load_mjcf(xml)
    system = mb.system("joint", limits=True, restitution=restitution)
    assert system.contact.names == ["pin lower", "pin upper"]
    run = ct.simulate(system, [0.2], [2.0], T=0.2, N=40, scheme="galerkin4")
    assert run.success, run.message
    assert run.detail.impacts[0].t == pytest.approx(0.05, abs=1e-10)
    expected = np.where(run.t <= 0.05, 0.2 + 2.0 * run.t,
                        0.3 if restitution == 0.0 else 0.3 - 2.0 * (run.t - 0.05))
    assert np.max(np.abs(run.q[:, 0] - expected)) < 1e-10


def test_bad_model_files_are_refused(tmp_path):
    with pytest.raises(InputError, match="no model file"):
        load_mjcf(str(tmp_path / "missing.xml"))
    with pytest.raises(InputError, match="MuJoCo could not load"):
        load_mjcf("<mujoco><worldbody><body><joint type='hinge'/></body></worldbody>")
    friction = MJCF.replace('damping="0.3"', 'frictionloss="0.1"')
    with pytest.raises(InputError, match="frictionloss"):
        load_mjcf(friction)
    with pytest.raises(InputError, match="ball joint"):
        load_mjcf(MJCF.replace('type="ball" pos', 'type="ball" damping="1" pos'))
    with pytest.raises(InputError, match="compound joint"):
        load_mjcf(MJCF).system("maximal")
    pytest.importorskip("yourdfpy")
    with pytest.raises(InputError, match="planar"):
        load_urdf(URDF.replace('type="continuous"', 'type="planar"'))
    with pytest.raises(InputError, match="no mass"):
        load_urdf(URDF.replace('<mass value="0.8"/>', '<mass value="0"/>'))
