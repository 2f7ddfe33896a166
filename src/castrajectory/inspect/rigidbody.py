"""Readings of a rigid-body trajectory: body rates, angular momenta, flips, and their errors.

The momenta are those of the method: the discrete Legendre transform ``p_k⁺ = −D₁L_d`` of a
whole-trajectory or marched variational solution (so that the discrete Noether theorem shows),
the continuous ``p = ∂L/∂q̇`` of a time-stepper.  Works for every
:class:`~castrajectory.solve.simulate.Run` of a system built by
:mod:`castrajectory.models.rigidbody`.
"""
from __future__ import annotations

import math
import numpy as np

from ..models import rigidbody as rb


def momenta(system, run) -> np.ndarray:
    """Node momenta of ``run``: the method's discrete momenta when it has them, else ``∂L/∂q̇``."""
    p = getattr(run.detail, "p", None)
    if p is not None and np.shape(p) == np.shape(run.q):
        return np.asarray(p, float)
    K = run.q.shape[0]
    return np.asarray(system.momentum.map(K)(run.q.T, run.v.T, np.asarray(run.t, float)[None, :])).T


def drift(x: np.ndarray) -> float:
    """``max_k |x_k − x_0| / max(|x_0|, tiny)`` of a scalar series (rows) or vector series (norm per row)."""
    x = np.asarray(x, float)
    d = x - x[0]
    if d.ndim > 1:
        return float(np.max(np.linalg.norm(d, axis=-1)) / max(float(np.linalg.norm(x[0])), 1e-300))
    return float(np.max(np.abs(d)) / max(abs(float(x[0])), 1e-300))


def _invariants(run) -> dict:
    """What every rigid-body run is checked for: the unit quaternion and the energy."""
    q = np.asarray(run.q, float)
    return {"quaternion_norm_error": float(np.max(np.abs(np.linalg.norm(q, axis=1) - 1.0))),
            "energy_drift": drift(np.asarray(run.energy, float))}


def free_body(system, run, inertia: rb.Inertia, omega0) -> dict:
    """Readings of a free rigid body: ω, spatial L, flips and the flip interval against the oracle.

    A *flip* is a sign change of the body rate about the axis the spin starts on (the largest
    component of the body angular momentum ``I ω₀``).  Started near the intermediate axis this is
    the intermediate-axis rate, the Dzhanibekov flip, every ``2K(m)/s``
    (:func:`~castrajectory.models.rigidbody.flip_interval`).  Started near the major or minor axis
    that rate never changes sign (the spin is stable): no flips, and ``flip_interval_exact`` is
    ``None``.  The measured interval is the least-squares slope of the flip times against their
    count (all flips weigh in; the first flip's phase does not).
    """
    q = np.asarray(run.q, float)
    omega = rb.body_rates(q, np.asarray(run.v, float))
    p = momenta(system, run)
    L = rb.spatial_momentum(q, p)
    Lnorm = np.linalg.norm(L, axis=1)
    w0 = np.asarray(omega0, float)
    axis = int(np.argmax(np.abs(inertia.moments * w0)))
    flips = rb.sign_changes(run.t, omega[:, axis])
    exact = rb.flip_interval(inertia, w0) if axis == rb.intermediate_axis(inertia) else math.inf
    measured = float(np.polyfit(np.arange(flips.size), flips, 1)[0]) if flips.size >= 2 else None
    err = abs(measured - exact) if measured is not None and math.isfinite(exact) else None
    return {
        "omega": omega,
        "flip_axis": axis,
        "flip_times": flips,
        "flip_interval": measured,
        "flip_interval_exact": exact if math.isfinite(exact) else None,
        "flip_interval_error": err,
        "angular_momentum": L,
        "angular_momentum_norm": Lnorm,
        "angular_momentum_drift": drift(L),
        "angular_momentum_norm_drift": drift(Lnorm),
        **_invariants(run),
    }


def heavy_top(system, run) -> dict:
    """Readings of the heavy top: tilt (nutation), precession angle, ``L_z`` and ``L₃``.

    Tilt and precession are those of the symmetry axis (:func:`~castrajectory.models.rigidbody.tilt_precession`).
    ``L_z`` (vertical, spatial) and ``L₃`` (the body symmetry axis) are the momentum
    maps of rotations about the vertical and about the symmetry axis.
    """
    q = np.asarray(run.q, float)
    tilt, precession = rb.tilt_precession(q)
    p = momenta(system, run)
    Lz = rb.spatial_momentum(q, p)[:, 2]
    L3 = rb.body_momentum(q, p)[:, 2]
    return {
        "tilt": tilt,
        "precession": precession,
        "angular_momentum_vertical": Lz,
        "angular_momentum_axis": L3,
        "angular_momentum_vertical_drift": drift(Lz),
        "angular_momentum_axis_drift": drift(L3),
        **_invariants(run),
    }
