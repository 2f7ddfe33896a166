"""The memory a whole-trajectory solve takes, and the largest grid that fits in what this process may
still fill (the solve refuses a grid beyond it; an ``rtol`` refinement stops at it).

The estimate per step is fitted to measurements (``scripts/bench_memory.py``); the room is the machine's
available memory, a control group's limit and the address-space limit (see :func:`_memory_room`).
"""
from __future__ import annotations

import os
from typing import Optional

import numpy as np

from ..discretise.lagrangians import discrete_mechanics
from ..discretise.trajectory import TrajectoryTranscription


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


def plan(system, scheme: str = "midpoint", polish: bool = False) -> tuple:
    """``(N, bytes per step, what bounds it)``: the largest N whose whole-trajectory solve fits in
    MEMORY_SHARE of the memory left to this process beyond MEMORY_RESERVE (estimate: :func:`bytes_per_step`;
    ``polish``: an ``rtol`` run's, POLISH_MEMORY_FACTOR times more; against an address-space limit,
    ADDRESS_SPACE_FACTOR times more again)."""
    resident, space = _memory_room()
    per = bytes_per_step(system, scheme) * (POLISH_MEMORY_FACTOR if polish else 1.0)
    plans = [(MEMORY_SHARE * max(resident - MEMORY_RESERVE, 0.0) / per, per, "the memory available"),
             (MEMORY_SHARE * max(space - MEMORY_RESERVE, 0.0) / (per * ADDRESS_SPACE_FACTOR),
              per * ADDRESS_SPACE_FACTOR, "the address-space limit")]
    n, per, what = min(plans, key=lambda p: p[0])
    return int(min(n, 2 ** 62)), per, what


def limit(system, scheme: str = "midpoint", polish: bool = False) -> int:
    """The largest N that fits (see :func:`plan`)."""
    return plan(system, scheme, polish)[0]
