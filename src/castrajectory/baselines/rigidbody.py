"""Euler's equations with quaternion kinematics: the rigid body's reference and RK4 baseline.

Written directly in body rates, independently of the Lagrangian machinery, so that they can
check it: for a body with a fixed point, principal moments ``I`` about that point and a
weight ``m g`` acting at the body point ``c``,

    I ω̇ = (I ω) × ω + m g Γ × c,        q̇ = ½ q ⊗ (0, ω),        Γ = R(q)ᵀ e_z

(Euler–Poisson; ``m g = 0`` gives the free body).  :func:`euler_reference` integrates them with
CVODES (Adams) at a tight tolerance; :func:`euler_rk4` is classical RK4 on the same equations,
*without* renormalising the quaternion (its norm drifts at the method's order).
"""
from __future__ import annotations

import time
from typing import Sequence, Tuple

import casadi as ca
import numpy as np

from ..discretise.lagrangians import rk4_step
from ..models import rigidbody as rb
from ..validation import InputError, integer_at_least, positive
from .stepping import Stepped


def _rhs(moments: Sequence[float], weight: float, com: Sequence[float]):
    """``(q, ω) ↦ (q̇, ω̇)`` of Euler–Poisson as a CasADi function of the state ``x = (q, ω)``."""
    x = ca.SX.sym("x", 7)
    q, w = x[:4], x[4:]
    Id = ca.DM(np.asarray(moments, float))
    Gamma = ca.mtimes(rb.rotation(q).T, ca.DM([0.0, 0.0, 1.0]))
    torque = weight * ca.cross(Gamma, ca.DM(np.asarray(com, float)))
    wdot = (ca.cross(Id * w, w) + torque) / Id
    qdot = 0.5 * rb.quat_multiply(q, ca.vertcat(0, w))
    return ca.Function("euler_poisson", [x], [ca.vertcat(qdot, wdot)])


def _check(q0, omega0) -> Tuple[np.ndarray, np.ndarray]:
    q0, w0 = np.asarray(q0, float).reshape(-1), np.asarray(omega0, float).reshape(-1)
    if q0.size != 4 or w0.size != 3 or not (np.all(np.isfinite(q0)) and np.all(np.isfinite(w0))):
        raise InputError("a rigid body's state is a finite quaternion (4) and body rate (3)")
    return q0, w0


def euler_reference(moments, q0, omega0, t_eval, weight: float = 0.0, com=(0.0, 0.0, 0.0),
                    rtol: float = 1e-12, atol: float = 1e-12) -> Tuple[np.ndarray, np.ndarray]:
    """CVODES solution of Euler–Poisson at the times ``t_eval``: ``(q, ω)`` rows."""
    q0, w0 = _check(q0, omega0)
    te = np.asarray(t_eval, float).reshape(-1)
    if te.size < 1 or te[0] < 0 or np.any(np.diff(te) <= 0):
        raise InputError("t_eval must be strictly increasing and start at t >= 0")
    f = _rhs(moments, weight, com)
    x = ca.SX.sym("x", 7)
    F = ca.integrator("euler_ref", "cvodes", {"x": x, "ode": f(x)}, 0.0, te,
                      {"abstol": positive("atol", atol), "reltol": positive("rtol", rtol),
                       "max_num_steps": 10 ** 7, "linear_multistep_method": "adams"})
    X = np.asarray(F(x0=np.concatenate([q0, w0]))["xf"]).reshape(7, te.size).T
    return X[:, :4].copy(), X[:, 4:].copy()


def euler_rk4(system, moments, q0, omega0, T: float, N: int, weight: float = 0.0,
              com=(0.0, 0.0, 0.0)) -> Stepped:
    """Classical RK4 on Euler–Poisson with quaternion kinematics (no renormalisation).

    ``system`` (the Lagrangian description of the same body) only supplies the energy; the
    returned :class:`Stepped` holds ``q`` and ``qd = ½ q ⊗ ω``, so every reading of a
    Lagrangian run applies to it.
    """
    q0, w0 = _check(q0, omega0)
    T, N = positive("T", T), integer_at_least("n", N, 2)
    h = T / N
    t0 = time.perf_counter()
    f = _rhs(moments, weight, com)
    x = ca.SX.sym("x", 7)
    march = ca.Function("rk4_step", [x], [rk4_step(f, x, h)]).mapaccum("rk4_euler", N)
    build = time.perf_counter() - t0
    t1 = time.perf_counter()
    X = np.asarray(march(np.concatenate([q0, w0])))
    solve = time.perf_counter() - t1
    X = np.vstack([np.concatenate([q0, w0]), X.T])
    q, w = X[:, :4], X[:, 4:]
    qd = rb.quaternion_rate(q, w)
    ok = bool(np.all(np.isfinite(X)))
    return Stepped(t=np.linspace(0.0, T, N + 1), q=q, qd=qd, energy=system.energies(q, qd),
                   method="rk4-euler", scheme=None, build_time_s=build, solve_time_s=solve, success=ok,
                   message="marched" if ok else "non-finite state")

