"""The peers of scripts/bench_held_contact.py: its two held-contact scenes modelled in MuJoCo and in pymunk.

Every function steps one run and returns its wall time (the stepping with the state read each step; building the
model excluded) and the samples the benchmark scores.  The models are planar in both tools:

* the ladder: the rod on slide x, slide z and a hinge (MuJoCo; a pymunk body is planar), its ends on a frictionless
  floor and wall.  The rod is a capsule (MuJoCo) or a rounded segment (pymunk) of radius ``ROD_RADIUS``, and the two
  planes are moved back by that radius, so that the centres of its end caps, the segment's ends, touch x = 0 and
  y = 0 exactly: the geometry is the castrajectory model's.  The wall's normal force is read each step.
* the disk in the bowl: a sphere (MuJoCo, its inertia the disk's m r²/2 about the hinge) or a circle (pymunk) on the
  same planar joints, and the bowl either
  - ``exact``: the bowl's tangent at the disk's polar angle, a plane on a mocap body (MuJoCo) or a segment on a
    kinematic body (pymunk) re-posed before every step.  The tool then computes the contact a concave circular
    primitive would give at the step's start (point, normal and gap exact; the surface at rest, so its slip is the
    disk's), and its own solver does the rest: neither tool has a concave primitive, or
  - ``facets``: ``n`` static flat facets (thin capsules in MuJoCo, segments in pymunk) over φ ∈ [−``FACET_ARC``,
    ``FACET_ARC``], placed so that the disk centre's locus straddles the circle of radius R − r: it deviates from it
    by at most (R − r)(1 − cos(Δ/2))/(1 + cos(Δ/2)) ≈ (R − r)Δ²/16, Δ = 2·FACET_ARC/n (:func:`facet_floor`).
"""
from __future__ import annotations

import importlib.util
import math
import time

import numpy as np

#: The ladder's end-cap radius (m): the planes sit this far behind x = 0 and y = 0.
ROD_RADIUS = 0.01
#: The faceted bowl covers the polar angles |φ| <= FACET_ARC (the disk stays within |φ| <= φ₀ = 0.5).
FACET_ARC = 0.6
#: The facets' thickness (MuJoCo: the capsules' radius), outside the bowl's surface (m).
FACET_THICKNESS = 0.005


def available(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


def _mujoco_contact(dt: float, stiff: bool) -> tuple[str, int]:
    """The geoms' contact attributes and the noslip iterations: MuJoCo's defaults, or (stiff) the smallest time
    constant it keeps stable (2 dt), impedance near 1 and 50 noslip passes (as scripts/bench_contact.py)."""
    if stiff:
        return f'solref="{2 * dt:.6g} 1" solimp="0.999 0.9999 0.001 0.5 2"', 50
    return "", 0


# ---------------------------------------------------------------------------------------------------------- ladder

def ladder_mujoco(dt, stiff, theta0, T, mass=1.0, length=1.0, g=9.81):
    """(wall s, (θ, the wall's normal force) at every step) for MuJoCo's planar rod."""
    import mujoco
    contact, noslip = _mujoco_contact(dt, stiff)
    rho, inertia = ROD_RADIUS, mass * length ** 2 / 12.0
    # hinge about +y: the body's x axis turns to (cos θ, 0, −sin θ), the foot (+x end) goes down and right
    xml = (f'<mujoco><option timestep="{dt:.6g}" gravity="0 0 {-g}" noslip_iterations="{noslip}"/><worldbody>'
           f'<geom name="floor" type="plane" size="10 10 0.1" pos="0 0 {-rho}" condim="1" friction="0 0 0" {contact}/>'
           f'<geom name="wall" type="plane" size="10 10 0.1" pos="{-rho} 0 0" zaxis="1 0 0" condim="1" '
           f'friction="0 0 0" {contact}/>'
           f'<body><joint type="slide" axis="1 0 0"/><joint type="slide" axis="0 0 1"/>'
           f'<joint type="hinge" axis="0 1 0"/><inertial pos="0 0 0" mass="{mass}" diaginertia="{inertia} '
           f'{inertia} {inertia}"/><geom type="capsule" fromto="{-length / 2} 0 0 {length / 2} 0 0" size="{rho}" '
           f'condim="1" friction="0 0 0" {contact}/></body></worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    data.qpos[:] = [0.5 * length * math.cos(theta0), 0.5 * length * math.sin(theta0), theta0]
    wall_id = model.geom("wall").id
    n = int(round(T / dt))
    theta, force = np.empty(n + 1), np.zeros(n + 1)
    theta[0] = theta0
    t0 = time.perf_counter()
    for k in range(1, n + 1):
        mujoco.mj_step(model, data)
        theta[k] = data.qpos[2]
        if data.ncon:
            con = data.contact
            on_wall = (con.geom[:, 0] == wall_id) | (con.geom[:, 1] == wall_id)
            if on_wall.any():                      # condim 1: one row per contact, its normal force
                force[k] = data.efc_force[con.efc_address[on_wall]].sum()
    return time.perf_counter() - t0, (theta, force)


def ladder_pymunk(dt, iterations, theta0, T, mass=1.0, length=1.0, g=9.81):
    """(wall s, (θ, the wall's normal force: its impulse over dt) at every step) for pymunk's rod."""
    import pymunk
    rho = ROD_RADIUS
    space = pymunk.Space()
    space.gravity = (0.0, -g)
    space.iterations = iterations
    space.collision_slop = 1e-6                    # its default 0.1 m would be a tenth of the rod
    floor = pymunk.Segment(space.static_body, (-10.0, -rho), (10.0, -rho), 0.0)
    wall = pymunk.Segment(space.static_body, (-rho, -10.0), (-rho, 10.0), 0.0)
    body = pymunk.Body(mass, mass * length ** 2 / 12.0)
    body.position = (0.5 * length * math.cos(theta0), 0.5 * length * math.sin(theta0))
    body.angle = -theta0                           # the foot, (L/2, 0) in the body, goes down and right
    rod = pymunk.Segment(body, (-0.5 * length, 0.0), (0.5 * length, 0.0), rho)
    for shape in (floor, wall, rod):
        shape.friction, shape.elasticity = 0.0, 0.0
    space.add(floor, wall, body, rod)
    n = int(round(T / dt))
    theta, force = np.empty(n + 1), np.zeros(n + 1)
    theta[0] = theta0
    impulse = [0.0]

    def on_wall(arbiter):
        if wall in arbiter.shapes:
            impulse[0] += abs(arbiter.total_impulse.x)

    t0 = time.perf_counter()
    for k in range(1, n + 1):
        space.step(dt)
        theta[k] = -body.angle
        impulse[0] = 0.0
        body.each_arbiter(on_wall)
        force[k] = impulse[0] / dt
    return time.perf_counter() - t0, (theta, force)


# ------------------------------------------------------------------------------------------------------------ disk

def facet_floor(n: int, r: float, R: float) -> tuple[float, float, float]:
    """(Δ, the facets' distance from the bowl's centre, the centre locus's largest radial deviation from R − r)."""
    delta = 2.0 * FACET_ARC / n
    c = math.cos(0.5 * delta)
    mid = (R - r) * 2.0 * c / (1.0 + c)            # the centre's distance at a facet's middle; mid / c at its ends
    return delta, mid + r, (R - r) - mid


def disk_mujoco(dt, stiff, bowl, phi0, T, mass=1.0, r=0.2, R=1.0, g=9.81, mu=1.0):
    """(wall s, q = (x, y, θ) at every step) for MuJoCo's planar disk; ``bowl`` is ``"exact"`` or a facet count."""
    import mujoco
    contact, noslip = _mujoco_contact(dt, stiff)
    inertia = 0.5 * mass * r * r
    if bowl == "exact":
        ground = (f'<body mocap="true"><geom type="plane" size="1 1 0.1" friction="{mu} 0 0" {contact}/></body>')
    else:
        delta, p, _ = facet_floor(bowl, r, R)
        half, axis = p * math.tan(0.5 * delta), p + FACET_THICKNESS
        caps = []
        for k in range(bowl):
            a = -FACET_ARC + (k + 0.5) * delta     # the facet's middle (polar angle from the bottom)
            cx, cz, tx, tz = axis * math.sin(a), -axis * math.cos(a), math.cos(a), math.sin(a)
            caps.append(f'<geom type="capsule" size="{FACET_THICKNESS}" fromto="{cx - half * tx:.17g} 0 '
                        f'{cz - half * tz:.17g} {cx + half * tx:.17g} 0 {cz + half * tz:.17g}" friction="{mu} 0 0" '
                        f'{contact}/>')
        ground = "".join(caps)
    # hinge about −y: θ counter-clockwise in the (x, z) plane, as castrajectory's θ in (x, y)
    xml = (f'<mujoco><option timestep="{dt:.6g}" gravity="0 0 {-g}" noslip_iterations="{noslip}"/><worldbody>'
           f'{ground}<body><joint type="slide" axis="1 0 0"/><joint type="slide" axis="0 0 1"/>'
           f'<joint type="hinge" axis="0 -1 0"/><inertial pos="0 0 0" mass="{mass}" diaginertia="{inertia} '
           f'{inertia} {inertia}"/><geom type="sphere" size="{r}" friction="{mu} 0 0" {contact}/></body>'
           f'</worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    data.qpos[:] = [(R - r) * math.sin(phi0), -(R - r) * math.cos(phi0), 0.0]
    n = int(round(T / dt))
    q = np.empty((n + 1, 3))
    q[0] = data.qpos
    t0 = time.perf_counter()
    if bowl == "exact":
        pos, quat, qpos = data.mocap_pos[0], data.mocap_quat[0], data.qpos
        for k in range(1, n + 1):
            x, z = qpos[0], qpos[1]
            phi = math.atan2(x, -z)
            # the tangent plane at R: its normal, the plane's z axis, turned by −φ about y, points inwards
            pos[0], pos[2] = R * math.sin(phi), -R * math.cos(phi)
            quat[0], quat[2] = math.cos(0.5 * phi), -math.sin(0.5 * phi)
            mujoco.mj_step(model, data)
            q[k] = qpos
    else:
        for k in range(1, n + 1):
            mujoco.mj_step(model, data)
            q[k] = data.qpos
    return time.perf_counter() - t0, q


def disk_pymunk(dt, iterations, bowl, phi0, T, mass=1.0, r=0.2, R=1.0, g=9.81, mu=1.0):
    """(wall s, q = (x, y, θ) at every step) for pymunk's disk; ``bowl`` is ``"exact"`` or a facet count.  Friction
    is the product of the two shapes' (the disk's mu, the bowl's 1)."""
    import pymunk
    space = pymunk.Space()
    space.gravity = (0.0, -g)
    space.iterations = iterations
    space.collision_slop = 1e-6
    if bowl == "exact":
        tangent = pymunk.Body(body_type=pymunk.Body.KINEMATIC)   # at rest: its velocities stay 0
        segments = [pymunk.Segment(tangent, (-1.0, 0.0), (1.0, 0.0), 0.0)]
        space.add(tangent)
    else:
        delta, p, _ = facet_floor(bowl, r, R)
        pv = p / math.cos(0.5 * delta)
        ends = [(pv * math.sin(-FACET_ARC + k * delta), -pv * math.cos(-FACET_ARC + k * delta))
                for k in range(bowl + 1)]
        segments = [pymunk.Segment(space.static_body, ends[k], ends[k + 1], 0.0) for k in range(bowl)]
    for segment in segments:
        segment.friction, segment.elasticity = 1.0, 0.0
    space.add(*segments)
    body = pymunk.Body(mass, 0.5 * mass * r * r)
    body.position = ((R - r) * math.sin(phi0), -(R - r) * math.cos(phi0))
    disk = pymunk.Circle(body, r)
    disk.friction, disk.elasticity = mu, 0.0
    space.add(body, disk)
    n = int(round(T / dt))
    q = np.empty((n + 1, 3))
    q[0] = body.position.x, body.position.y, body.angle
    t0 = time.perf_counter()
    for k in range(1, n + 1):
        if bowl == "exact":
            x, y = body.position
            phi = math.atan2(x, -y)
            tangent.position, tangent.angle = (R * math.sin(phi), -R * math.cos(phi)), phi
            space.reindex_shapes_for_body(tangent)
        space.step(dt)
        q[k] = body.position.x, body.position.y, body.angle
    return time.perf_counter() - t0, q
