"""The memory a solve takes, and the largest size that fits in what this process may still fill: a solve
refuses a size beyond it before anything is built (an ``rtol`` refinement stops at it).

Every family's estimate is fitted to the peak memory measured against its size (resident and virtual, each in
a fresh process): the whole trajectory per step (``scripts/bench_memory.py``), the droplet per segment
(:func:`droplet_cost`) and optimal control per step (:func:`control_cost`).  The room is the machine's
available memory, a control group's limit and the address-space limit (see :func:`_memory_room`), and the
same rule holds for every family: a size fits when its estimate is at most MEMORY_SHARE of the room left
beyond MEMORY_RESERVE.
"""
from __future__ import annotations

import math
import numbers
import os
from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from ..discretise.lagrangians import discrete_mechanics
from ..discretise.trajectory import TrajectoryTranscription
from ..validation import InputError


#: Memory of a whole-trajectory solve per step (bytes): BYTES_PER_UNKNOWN per unknown of a step and
#: BYTES_PER_NONZERO per nonzero of its constraint Jacobian (what MUMPS' factors grow with), and
#: BYTES_PER_CONTACT per contact.  Fitted to the peak resident memory against N of one simulate() in a
#: fresh process (``scripts/bench_memory.py``) and rounded up so that the estimate bounds every case
#: measured: the double pendulum (2 unknowns and 12 nonzeros per step with midpoint: 4.9 kB measured;
#: galerkin4 4/32: 12.8 kB; galerkin8 8/96: 22 kB), the quaternion body (midpoint 5/56: 19 kB;
#: galerkin4 10/144: 49 kB; galerkin8 20/416: 84 kB), chains of 8 and 16 links (midpoint 16/768: 140
#: kB; galerkin4 32/2048: 377 kB) and the bouncing ball (contact, midpoint: 11 kB).
BYTES_PER_UNKNOWN = 3000.0
BYTES_PER_NONZERO = 200.0
BYTES_PER_CONTACT = 12000.0
#: The share of the memory left to this process that a grid may fill, after MEMORY_RESERVE (the rest: the
#: levels and the estimate's grid beside it, and the process's own growth: thread stacks and malloc
#: arenas, which count against an address-space limit long before they are touched).  Measured under
#: RLIMIT_AS, the double pendulum (midpoint, --rtol 1e-13) refined from N = 4000: with 0.5 GB beyond the
#: space mapped after a first small solve, the reserve-free limit let a solve abort with std::bad_alloc;
#: 0.6-2 GB stopped at the limit with the tolerance message (N = 53 000 - 187 000).
MEMORY_SHARE = 0.8
MEMORY_RESERVE = 256e6
#: Under an address-space limit the virtual size counts, which grows faster than the resident memory:
#: MUMPS reserves its workspace with a margin (Ipopt's mumps_mem_percent) that is never touched.
#: Measured (scripts/bench_memory.py): virtual / resident per step 1.0-3.1 (the quaternion body with
#: galerkin4: 138 against 49 kB); the estimate is scaled by this factor against such a limit.
ADDRESS_SPACE_FACTOR = 3.0
#: A run with ``rtol`` polishes each answer with a sparse-QR Newton step (_polish), whose factors come on
#: top: measured peak of a refinement ending at N over that of one solve at N (resident, beyond the
#: process's start): 1.03 (bouncing ball) to 1.86 (quaternion body, galerkin4, N = 16 000).
POLISH_MEMORY_FACTOR = 2.0


def _read_int(path: str) -> Optional[int]:
    try:
        with open(path) as fh:
            text = fh.read().split()[0]
        return int(text)
    except (OSError, ValueError, IndexError):
        return None


def _memory_room() -> tuple:
    """The memory this process may still fill, ``(resident, address space)`` in bytes: resident, this
    machine's available memory (``MemAvailable``, or its physical memory where that is unknown) within a
    control group's ``memory.max`` (less its use); address space, the ``RLIMIT_AS`` left beyond what is
    mapped already (infinite without a limit)."""
    resident = []
    try:
        with open("/proc/meminfo") as fh:
            info = {ln.split(":")[0]: ln.split()[1] for ln in fh if ":" in ln}
        resident.append(float(info["MemAvailable"]) * 1024.0)
    except (OSError, KeyError, ValueError, IndexError):
        try:
            resident.append(float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")))
        except (ValueError, OSError, AttributeError):
            pass
    cap, used = _read_int("/sys/fs/cgroup/memory.max"), _read_int("/sys/fs/cgroup/memory.current")
    if cap is not None:
        resident.append(float(cap - (used or 0)))
    space = float("inf")
    try:
        import resource
        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
        if soft != resource.RLIM_INFINITY:
            mapped = _read_int("/proc/self/statm")
            space = float(soft) - (mapped * os.sysconf("SC_PAGE_SIZE") if mapped is not None else 0.0)
    except (ImportError, ValueError, OSError, AttributeError):
        pass
    return (max(min(resident), 0.0) if resident else float("inf")), max(space, 0.0)


def bytes_per_step(system, scheme: str = "midpoint") -> float:
    """Estimated memory of a whole-trajectory solve per step (bytes; see BYTES_PER_UNKNOWN): the unknowns
    and Jacobian nonzeros of one step, read from the transcriptions of 4 and 8 steps (no solver built)."""
    dm = discrete_mechanics(system, scheme)
    n = system.nq
    counts = []
    for N in (4, 8):
        tn = TrajectoryTranscription(dm, N, float(N), "initial_value", np.zeros(n), np.zeros(n))
        counts.append((tn.nlp.sizes()["variables"], tn.nlp.jacobian_nonzeros()))
    du, dnz = ((b - a) / 4.0 for a, b in zip(*counts))
    per = BYTES_PER_UNKNOWN * du + BYTES_PER_NONZERO * dnz
    return per + (BYTES_PER_CONTACT * system.ncontact if system.contact is not None else 0.0)


def _rooms() -> list:
    """``[(bytes a run may fill, which estimate counts, what bounds it)]``: MEMORY_SHARE of the memory left to this
    process beyond MEMORY_RESERVE, resident (``0``) and address space (``1``; see :func:`_memory_room`)."""
    resident, space = _memory_room()
    return [(MEMORY_SHARE * max(resident - MEMORY_RESERVE, 0.0), 0, "the memory available"),
            (MEMORY_SHARE * max(space - MEMORY_RESERVE, 0.0), 1, "the address-space limit")]


def plan(system, scheme: str = "midpoint", polish: bool = False) -> tuple:
    """``(N, bytes per step, what bounds it)``: the largest N whose whole-trajectory solve fits in
    MEMORY_SHARE of the memory left to this process beyond MEMORY_RESERVE (estimate: :func:`bytes_per_step`;
    ``polish``: an ``rtol`` run's, POLISH_MEMORY_FACTOR times more; against an address-space limit,
    ADDRESS_SPACE_FACTOR times more again)."""
    per = bytes_per_step(system, scheme) * (POLISH_MEMORY_FACTOR if polish else 1.0)
    plans = [(usable / (per * ADDRESS_SPACE_FACTOR ** kind), per * ADDRESS_SPACE_FACTOR ** kind, what)
             for usable, kind, what in _rooms()]
    n, per, what = min(plans, key=lambda p: p[0])
    return int(min(n, 2 ** 62)), per, what


def limit(system, scheme: str = "midpoint", polish: bool = False) -> int:
    """The largest N that fits (see :func:`plan`)."""
    return plan(system, scheme, polish)[0]


# ----------------------------------------------------------------------------- every family: a measured cost
@dataclass(frozen=True)
class Cost:
    """The peak memory of a run of size ``n`` beyond what its process had mapped before it, fitted to
    measurements: ``c0 + c1 n + c2 n²`` bytes, ``resident`` (what the machine's memory holds) and ``virtual``
    (the address space, what RLIMIT_AS counts: it grows faster, MUMPS reserves its workspace with a margin it
    never touches, and loading Ipopt maps some 0.4 GB of libraries, thread stacks and malloc arenas at once).
    ``unit``: what ``n`` counts, for the message."""

    resident: Tuple[float, float, float]
    virtual: Tuple[float, float, float]
    unit: str = "step"

    def estimate(self, n: float, kind: int = 0) -> float:
        c0, c1, c2 = self.virtual if kind else self.resident
        return c0 + c1 * n + c2 * n * n

    def largest(self, usable: float, kind: int = 0) -> int:
        """The largest ``n`` whose estimate is at most ``usable`` bytes (0 if none)."""
        c0, c1, c2 = self.virtual if kind else self.resident
        room = usable - c0
        if room < 0.0:
            return 0
        if math.isinf(room):
            return 2 ** 62
        if c2 > 0.0:
            n = (2.0 * room) / (c1 + math.sqrt(c1 * c1 + 4.0 * c2 * room))
        else:
            n = room / c1 if c1 > 0.0 else float("inf")
        return int(min(n, 2 ** 62))


def check(n: int, cost: Cost, program: str, name: str = "n", least: int = 2) -> None:
    """Refuse a run of size ``n`` whose estimated peak memory (``cost``) exceeds what this process may fill, in
    one sentence: the estimate, the room it exceeds and the largest size that fits (see :func:`_rooms`).  Nothing
    is built; ``least``: the smallest size the run accepts (below it, no size fits)."""
    if not isinstance(n, numbers.Integral):
        return  # (the caller's own check refuses it)
    fits = [(cost.largest(usable, kind), usable, kind, what) for usable, kind, what in _rooms()]
    top, usable, kind, what = min(fits, key=lambda f: f[0])
    if n <= top:
        return
    need = cost.estimate(n, kind)
    raise InputError(
        f"{name} = {n} needs about {_size(need)} of {'address space' if kind else 'memory'} for {program} "
        f"(measured, about {_per_unit(cost, n, kind)}), more than the {_size(usable)} this process may fill "
        f"within {what}" + (f": use {name} <= {top}" if top >= least else " (no size fits)"))


def _size(b: float) -> str:
    """``b`` bytes in kB, MB, GB or TB, three digits."""
    for scale, unit in ((1e12, "TB"), (1e9, "GB"), (1e6, "MB")):
        if b >= scale:
            return f"{b / scale:.3g} {unit}"
    return f"{b / 1e3:.3g} kB"


def _per_unit(cost: Cost, n: int, kind: int) -> str:
    c0, c1, c2 = cost.virtual if kind else cost.resident
    return f"{_size(c1 + c2 * n)} per {cost.unit}" + (" at this size, growing with n" if c2 > 0.0 else "")


# ----------------------------------------------------------------------------- the droplet
#: Peak memory of ``droplet.solve`` (the error estimate's solves at N/2 and N/4 included), fitted to the peak
#: resident and virtual size against N of one solve in a fresh process (``/usr/bin/time``-like: ``ru_maxrss``
#: and ``VmPeak`` less those after the imports) and rounded up so that the estimate bounds every case measured
#: (ratios estimate / measured 1.0-1.8).  Per segment, resident and virtual:
#:
#: * the curve (2-D): 11.1-11.9 kB and 25-29 kB measured (N = 1e5, 2e5, 4e5; a pinned span, a pattern and a
#:   heavy drop without the oracle 11.8-14.4 kB and 28-34 kB at 5e4 and 1e5);
#: * the graph: 5.5-5.7 kB and 15-16 kB (N = 1e5, 2e5);
#: * the drop of revolution (its half profile): 12.4-15.6 kB and 28-33 kB (N = 5e4, 1e5, 2e5; a heavy one
#:   without the oracle, 14.6 and 34 kB at 5e4).
DROPLET_BYTES_PER_SEGMENT = {"curve": (16e3, 36e3), "graph": (8e3, 20e3), "revolution": (18e3, 40e3)}
#: A heavy drop's errors against its oracle (``compare``): the vertices' distance to the closed-form profile
#: sampled at 128 points per segment (:meth:`HeavyDrop.distance`), which costs more than the solve itself:
#: measured 284-290 kB (resident) and 329-446 kB (virtual) per segment in 2-D (N = 2000, 4000, 8000), and the
#: Young-Laplace shooting of a drop of revolution 74-93 kB and 98-396 kB (N = 1000 - 20000; the smaller N carry
#: the fixed cost of its 20 000 samples at least).
DROPLET_ORACLE_BYTES_PER_SEGMENT = {False: (300e3, 340e3), True: (90e3, 100e3)}
#: A pendant drop's stability: the dense reduced Hessian of every continuation step (:mod:`.second_order`,
#: eigen-decompositions of matrices of 2N unknowns squared), bytes per segment squared.  Measured with the
#: oracle's and the solve's per segment beside it, 2-D: 138, 417 and 885 MB at N = 400, 800 and 1200 (a fit
#: of 125 kB N + 495 B N²); a drop of revolution 130 and 417 MB at N = 400 and 800.
DROPLET_STABILITY_BYTES = 600.0
#: The spectral profile (``n`` its degree, at most 200): dense in the degree, bytes per degree squared,
#: resident and virtual: measured 65, 205, 422 and 744 MB resident, 410, 598, 851 and 1259 MB virtual at
#: degrees 50, 100, 150 and 200 (a drop of revolution, pendant, at 200: 726 and 1264 MB).
SPECTRAL_BYTES = (21e3, 25e3)
#: What every droplet solve maps at once beyond the imports (Ipopt, MUMPS, threads): 27 MB resident and
#: 336 MB virtual at N = 1000 (curve).
DROPLET_FIXED = (30e6, 400e6)


def droplet_cost(drop, formulation: str, compare: bool = True) -> Cost:
    """The measured peak memory of :func:`castrajectory.solve.droplet.solve` against ``n`` for ``drop`` in
    ``formulation`` (``compare``: with its errors against the oracle).  See DROPLET_BYTES_PER_SEGMENT."""
    (f0, fv) = DROPLET_FIXED
    if formulation == "spectral":
        return Cost((f0, 0.0, SPECTRAL_BYTES[0]), (fv, 0.0, SPECTRAL_BYTES[1]), "degree")
    per, per_v = DROPLET_BYTES_PER_SEGMENT["revolution" if drop.axisymmetric else formulation]
    if compare and drop.rho_g > 0.0:
        extra, extra_v = DROPLET_ORACLE_BYTES_PER_SEGMENT[bool(drop.axisymmetric)]
        per, per_v = per + extra, per_v + extra_v
    quad = DROPLET_STABILITY_BYTES if drop.pendant else 0.0
    return Cost((f0, per, quad), (fv, per_v, quad), "segment")


def check_droplet(drop, n: int, formulation: str, compare: bool = True) -> None:
    """Refuse a droplet of ``n`` segments (the spectral profile: degree ``n``) that this process cannot hold
    (see :func:`check`)."""
    what = f"the droplet's {formulation} NLP" + (" with its oracle" if compare and drop.rho_g > 0.0 else "")
    check(n, droplet_cost(drop, formulation, compare), what, least=4 if formulation == "spectral" else 3)


# ----------------------------------------------------------------------------- optimal control
#: Peak memory of ``OptimalControl.solve`` (its ladder of coarser grids and the certificate's march included) per
#: step: CONTROL_BYTES_PER_UNKNOWN per unknown and CONTROL_BYTES_PER_NONZERO per constraint-Jacobian nonzero
#: of a step (read from the transcriptions of 4 and 8 steps, as for the whole trajectory), resident and
#: virtual, beside CONTROL_FIXED.  Fitted to the peak of one run of the scene's script in a fresh process
#: (``ru_maxrss`` and ``VmPeak`` less those after the solver's imports) against N, and rounded up so that the
#: estimate bounds every case (ratios estimate / measured 1.45-2.9 resident, 1.24-1.83 virtual): block_move
#: (2 unknowns and 5 nonzeros per step with midpoint: 4.7, 3.7, 3.4 kB per step resident at N = 2e4, 4e4,
#: 8e4; galerkin4 5/11: 10.2-7.7 kB at 1e4-4e4), cartpole_swingup (3/16: 13.0-11.3 kB; galerkin4 7/39: 30.9
#: and 30.1 kB), pendulum_swingup (2/5: 7.9, 6.9 kB at 1e4, 2e4: the counts do not see its sines), min_time
#: (free final time, 2/6: 7.9-4.9 kB), damped_transfer (galerkin6, a control per step, 4/19: 9.0 kB).  Virtual:
#: 7.7 kB (block_move) to 75 kB (cartpole, galerkin4) per step beyond some 0.4 GB mapped at once.
CONTROL_BYTES_PER_UNKNOWN = (1000.0, 2000.0)
CONTROL_BYTES_PER_NONZERO = (1000.0, 2000.0)
CONTROL_FIXED = (60e6, 450e6)
#: A system with holonomic constraints grows faster than linearly (MUMPS's factors fill in, it seems): the
#: satellite slew, a quaternion with its norm constraint, took 97, 272 and 1277 MB resident at N = 1000, 2000 and
#: 5000 (a fit of 56 kB N + 40 B N²; 2.0 GB virtual at 5000; its 2 Ipopt iterations took 10 s at 2000, the whole run
#: 248 s at 5000), a pendulum in Cartesian coordinates (not converged) 45, 122 and 353 MB at 1000, 2000 and 4000 (14 B
#: N²).  Bytes per step squared, per coordinate and constraint, resident and virtual alike (the satellite's
#: estimate over its peak: 2.0, 1.6 and 1.3 resident, 1.3 virtual at 5000).
CONTROL_CONSTRAINED_BYTES = 12.0
#: Contact-implicit optimal control (``solve_contact_control``) per step and contact on top: its complementarity
#: variables, sub-nodes and homotopy rounds.  Measured on block_push (one contact with friction): 93 and 161 MB
#: resident, 482 and 660 MB virtual at N = 500 and 1000 (estimate / measured 1.8, 1.7 resident, 1.4, 1.3 virtual;
#: 114 s and 391 s: its time grows faster than its memory); the hopper (4 coordinates) at N = 200 and 400, stopped
#: by its iteration budget: 70 and 78 MB resident against 108 and 156 MB estimated.
CONTACT_CONTROL_BYTES_PER_CONTACT = (200e3, 400e3)


def control_cost(ocp) -> Cost:
    """The measured peak memory of ``ocp.solve()`` (an :class:`~castrajectory.solve.optimal_control.OptimalControl`)
    against its number of steps.  See CONTROL_BYTES_PER_UNKNOWN."""
    import casadi as ca

    from ..discretise.optimal_control import ControlTranscription
    s = ocp.system
    dm = discrete_mechanics(s, ocp.scheme, ocp.control_points)
    path = [(ca.Function(f"g{j}", [s.q, ocp._u, s.t], [g]), lb, ub) for j, (g, lb, ub) in enumerate(ocp._path)]
    counts = []
    for N in (4, 8):
        nlp = ControlTranscription(dm, N, ocp.T, ocp._start, ocp._end, None, None, path).nlp
        counts.append((nlp.sizes()["variables"], nlp.jacobian_nonzeros()))
    du, dnz = ((b - a) / 4.0 for a, b in zip(*counts))
    per = [CONTROL_BYTES_PER_UNKNOWN[k] * du + CONTROL_BYTES_PER_NONZERO[k] * dnz for k in (0, 1)]
    if s.contact is not None:
        per = [per[k] + CONTACT_CONTROL_BYTES_PER_CONTACT[k] * s.ncontact for k in (0, 1)]
    quad = CONTROL_CONSTRAINED_BYTES * s.nq * s.nc
    return Cost((CONTROL_FIXED[0], per[0], quad), (CONTROL_FIXED[1], per[1], quad), "step")


def check_control(ocp) -> None:
    """Refuse an optimal-control problem of more steps than this process can hold (see :func:`check`)."""
    what = "the contact-implicit control program" if ocp.system.contact is not None else "the DMOC program"
    check(ocp.N, control_cost(ocp), what)
