"""One step of the discrete march: the compiled step of the transcription's rows and its Newton solve in given
modes, and the chunk of steps that keep their modes (the search for a step's modes is :mod:`.search`, the
vocabulary :mod:`.modes`, the march :mod:`.march`)."""
from __future__ import annotations

from typing import Optional

import casadi as ca
import numpy as np

from ...discretise.contact.elements import ContactMechanics
from .. import jit
from .options import MarchOptions
from .modes import CLOSES, DOWN, FIX, FREE, HELD, SLIDE, SLIDING_UP, STICK, TIMES_SUB, UP, E, F, G, I, K, N, P, T, W, releases, slips_after



class _Step:
    """The compiled step of ``cm`` (``ContactMechanics.march_step``) with the scene's scales."""

    def __init__(self, cm: ContactMechanics, scales, options: Optional[MarchOptions] = None):
        self.cm = cm
        #: the march's settings
        self.o = options if options is not None else MarchOptions()
        # evaluated once per Newton step of every marched step: compiled once per system (jit's disk
        # cache; CasADi's VM where that is not possible)
        self.fn = cm.derived("march step compiled", lambda: jit.compiled(cm.march_step))
        self.packed = cm.derived("march step packed", lambda: _packed(self.fn))
        # (the step with the timed contact forces, modes E and G: built, not compiled, where a step first times one)
        self._packed_timed = lambda: cm.derived("march step timed packed", lambda: _packed(cm.march_step_timed))
        self._chunks = cm.derived("march chunks", dict)
        self.ell, self.pref, self.vref = scales[0], scales[1], scales[2]
        self.n, self.c, self.m = cm.n, cm.c, cm.m
        # friction: two ratios ρ per contact (node force, sub-node impulse) at the end of the unknowns, and
        # the friction modes of the previous step (the march sets them: a contact that stuck starts sticking)
        self.nf = cm.nfr
        self.fd = cm.fd
        self.fprev = [FREE] * (2 * cm.c)
        #: the control of the step marched (optimal control through contact): the last input of every element
        #: that holds the step's forces (an empty one without controls)
        self.uarg = [np.zeros(0)]
        #: the start time of the step marched (the march sets it; the input before the controls)
        self.t0 = 0.0
        #: the last step solved: its released contacts' shares (μ⁻) and each contact's smallest force at the stages
        #: of its two parts (:mod:`.search`)
        self.last_mul = np.zeros(cm.c)
        self.last_lc = (np.zeros(cm.c), np.zeros(cm.c))
        #: the contacts held at the start of the step searched
        self.held_start = np.zeros(cm.c, bool)

    def chunk(self, K: int, q, p, h, held, fmodes=None, x0=None, controls=None):
        """``K`` steps from ``(q, p)`` in one call, the ``held`` contacts held (mode H) and the others
        open (β = 0), with friction the slots in the friction modes ``fmodes`` (stick or slide, kept through
        the chunk): columns of the nodes ``q_{k+1}``, momenta ``p_{k+1}⁻``, unknowns, sub-node and node
        gaps, each step's largest row residual in units of the unknowns (as :meth:`solve` measures it), and
        the slip velocities.  ``chunk_newton`` (:class:`.options.MarchOptions`) Newton steps from the previous step's flight and its forces
        (``x0``, the step before the chunk's: its forces and friction ratios start the first step's Newton,
        whose friction rows are singular at zero force)."""
        key = (K, self.o.chunk_newton)
        if key not in self._chunks:
            cm, n, c, m = self.cm, self.n, self.c, self.m
            qs, ps, hs, hm = ca.MX.sym("q", n), ca.MX.sym("p", n), ca.MX.sym("h"), ca.MX.sym("held", c)
            sc = [ca.MX.sym(name) for name in ("ell", "snu", "smu", "vref")]
            zero = ca.DM.zeros(c)
            # the friction modes of the chunk (kept through it; inputs with no entries without friction)
            st, sg = ca.MX.sym("stick", cm.nfs), ca.MX.sym("sgn", cm.nfs)
            fz = [st, sg, ca.DM.zeros(cm.nfs), ca.DM.zeros(cm.nfr), ca.DM.zeros(cm.nfs // 2), ca.DM.zeros(cm.nfl)]
            xs = ca.MX.sym("x0", cm.nx)
            us = [ca.MX.sym("u", cm.nu)]
            ts = ca.MX.sym("t")             # the step's start (a mapped input, one per step of the chunk)
            v = ca.solve(cm.system.mass_matrix(qs), ps)
            qm_, qn_ = qs + 0.5 * hs * v, qs + hs * v
            # the flight's guess of the positions (and stages), the previous step's forces, ratios, multipliers
            x = ca.vertcat(qm_, qn_, ca.DM.zeros(1), xs[2 * n + 1:2 * n + 1 + 2 * c + 2 * m + self.nf],
                           _stage_line(cm, qs, qm_, qn_), xs[cm.layout["lam_stage"]],
                           ca.DM.zeros(cm.layout["mul"].stop - cm.layout["mul"].start + self.nf // 2),
                           xs[cm.layout["lam_cstage"]], xs[cm.layout["fstage"]])
            for _ in range(self.o.chunk_newton):
                r, J = self.fn(x, qs, ps, hs, *sc, 0.0, zero, hm, hm, zero, zero, zero, zero, zero, zero, zero, zero,
                               zero, zero, zero, *fz, ts, *us)
                x = x - ca.solve(J, r)
            # the size of one more Newton step: the rows' residual in units of the unknowns
            r, J = self.fn(x, qs, ps, hs, *sc, 0.0, zero, hm, hm, zero, zero, zero, zero, zero, zero, zero, zero, zero,
                           zero, zero, *fz, ts, *us)
            res = ca.mmax(ca.fabs(ca.solve(J, r)))
            qn, qt = x[n:2 * n], x[:n]
            zp = [x[cm.layout["zs"]][cm.s:]]
            zz = x[cm.layout["zs"]]
            slip = cm.slip_row(qs, qt, qn, 0.0, hs, zero, zz[:cm.s], zz[cm.s:]) if self.nf else ca.DM.zeros(1)
            # (the stages' slip velocities, with friction and stages)
            vz = cm.stage_vel_row(qs, qt, qn, 0.0, hs, zz[:cm.s], zz[cm.s:]) if cm.nfz else ca.DM.zeros(1)
            one = ca.Function("chunk_step", [qs, ps, xs, hs, hm] + sc + [st, sg, ts] + us,
                              [qn, cm.p_node_minus(qt, 0.0, qn, hs, *zp, ts, *us), x, cm.gap_row(qt), cm.gap_row(qn), res, slip,
                               vz])
            self._chunks[key] = one.mapaccum("chunk_steps", K, [0, 1, 2], [0, 1, 2])
        fargs = self._friction_modes(fmodes)[:2]
        x0 = np.zeros(self.cm.nx) if x0 is None else x0
        # (the controls of the chunk's steps as columns, one per step: a mapped input)
        uargs = [np.asarray(controls, float).reshape(K, self.cm.nu).T]
        ts = (self.t0 + h * np.arange(K))[None, :]       # (the chunk's steps' start times, one column each)
        out = self._chunks[key](q, p, x0, h, held.astype(float), self.ell, self.pref / h, self.pref, self.vref, *fargs,
                              ts, *uargs)
        return tuple(np.asarray(a) for a in out)

    def _friction_modes(self, fmodes):
        """The masks of the friction modes per slot: sticking, the slip's sign of sliding, a fixed ratio (no entries
        without friction)."""
        nfs = self.cm.nfs            # (the march keeps a mode per slot also without friction: no entries then)
        fm = list(fmodes)[:nfs] if fmodes else [FREE] * nfs
        return (np.array([f == STICK for f in fm], float),
                np.array([1.0 if f in SLIDING_UP else -1.0 if f == DOWN else 0.0 for f in fm]),
                np.array([f == FIX for f in fm], float))

    def friction_holds(self, fm, rho, slip, rz=None, vz=None) -> np.ndarray:
        """Per column (step) of ratios ``rho`` and slips ``slip`` (with the stages' ratios ``rz`` and slip velocities
        ``vz``, with stages): every slot's friction mode holds, at the slot and at the stages of its part (sticking
        inside the cone; sliding with the slip's sign, on a tangent plane a slip that has not vanished)."""
        c, d = self.c, self.fd
        muf = np.concatenate([self.cm.mu_f, self.cm.mu_f])[:, None]
        K = rho.shape[1]
        R, S = rho.reshape(2 * c, d, K)[None], slip.reshape(2 * c, d, K)[None]
        if self.cm.nfz and rz is not None:
            st = self.cm.dm.scheme.stages
            by_slot = lambda v: np.concatenate([v[0], v[1]], axis=1)  # noqa: E731
            R = np.concatenate([R, by_slot(rz.reshape(2, st, c, d, K))])
            S = np.concatenate([S, by_slot(vz.reshape(2, st, c, d, K))])
        rn, sn = np.linalg.norm(R, axis=2), np.linalg.norm(S, axis=2)
        tol = 1e-12 * self.vref
        ok = np.ones(K, bool)
        for i, f in enumerate(fm):
            if f == STICK:
                ok &= np.all(rn[:, i] <= muf[i] * (1 + 1e-10), axis=0)
            elif f == UP:
                ok &= np.all(S[:, i, 0] >= -tol, axis=0)
            elif f == DOWN:
                ok &= np.all(S[:, i, 0] <= tol, axis=0)
            elif f == SLIDE:
                ok &= np.all(sn[:, i] > 1e-10 * self.vref, axis=0)
        return ok

    def masks(self, modes):
        c = self.c
        t, held, closed, law, node, fixed, nfixed = (np.zeros(c) for _ in range(7))
        for j, m in enumerate(modes):
            nfixed[j] = m == P
            t[j] = m in TIMES_SUB
            held[j] = m in HELD
            closed[j] = m in CLOSES
            law[j] = m == I
            node[j] = m == N
            fixed[j] = m in (F, T)
        # simultaneous impacts share one timing row: only the first timing contact times the sub-node
        timing = np.where(t > 0)[0]
        if timing.size > 1:
            t[timing[1:]] = 0.0
        return (t, held, closed, law, node, fixed, nfixed, releases(modes), np.array([float(m == K) for m in modes]),
                np.array([float(m == W) for m in modes]), np.array([float(m == E) for m in modes]),
                np.array([float(m == G) for m in modes]))

    def solve(self, x, q, p, h, modes, bfix=None, mufix=None, fmodes=None, rfix=None, mufixl=None, rfixl=None):
        """Newton on the step's rows in the given modes (with ``bfix``: the sub-node's ``β`` fixed
        there instead of timed by a contact; ``mufix``: the impulses of the contacts in modes F and T;
        ``rfix``: the friction ratios of the slots in friction mode FIX; ``mufixl``, ``rfixl``: the first part's
        closing impulses and ratios of the contacts in mode K); ``(x, ok)``."""
        n, c = self.n, self.c
        self.snu, self.smu = self.pref / h, self.pref
        t, held, closed, law, node, fixed, nfixed, release, leftfix, tslip, tlift, tgrip = self.masks(modes)
        if bfix is not None:
            t = np.zeros(c)
            x = x.copy()
            x[2 * n] = bfix
        args = (q, p, h, self.ell, self.snu, self.smu, self.vref, 0.0 if bfix is None else bfix,
                t, held, closed, law, node, fixed, np.zeros(c) if mufix is None else mufix, nfixed, release, leftfix,
                np.zeros(c) if mufixl is None else mufixl, tslip, tlift, tgrip)
        stick, sgn, fix = self._friction_modes(fmodes)
        nfs = self.cm.nfs
        args = args + (stick, sgn, fix, np.zeros(self.cm.nfr) if rfix is None else rfix,
                       slips_after(modes)[:nfs // 2],
                       np.zeros(self.cm.nfl) if rfixl is None else rfixl)
        small = 0
        size0 = 1.0 + float(np.max(np.abs(x)))
        packed = self._packed_timed() if np.any(tlift) or np.any(tgrip) else self.packed
        # (the inputs other than x packed into one vector, once: a call of two numeric inputs and one output costs half
        # of one with the step's 28 inputs and two outputs; docs/notes.md)
        args = np.concatenate([np.asarray(a, float).reshape(-1, order="F") for a in (*args, self.t0, *self.uarg)])
        nx = x.size
        for _ in range(self.o.newton_iter):
            out = _evaluated(packed, x, args)
            if out is None:
                return x, False
            r, Jr = out[:nx], out[nx:].reshape(nx, nx, order="F")
            # rows and columns equilibrated (momentum rows ~ 1/h², gap rows ~ 1/ℓ): the step's
            # rounding then stays at the level of the unknowns, not of the Jacobian's condition
            # (a trial far from the step's solution may overflow: it is refused, quietly)
            with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
                rs = 1.0 / np.maximum(np.max(np.abs(Jr), axis=1), 1e-300)
                cs = 1.0 / np.maximum(np.max(np.abs(Jr * rs[:, None]), axis=0), 1e-300)
                A = Jr * rs[:, None] * cs[None, :]
                if not (np.all(np.isfinite(A)) and np.all(np.isfinite(r))):
                    return x, False
                try:
                    dx = cs * np.linalg.solve(A, -r * rs)
                except np.linalg.LinAlgError:
                    try:
                        dx = cs * np.linalg.lstsq(A, -r * rs, rcond=None)[0]
                    except np.linalg.LinAlgError:
                        return x, False
            x = x + dx
            if not np.all(np.isfinite(x)):
                return x, False
            # converged: two steps in a row at the level of rounding (the second refines the first)
            small = small + 1 if np.max(np.abs(dx)) <= 1e-14 * (1.0 + float(np.max(np.abs(x)))) else 0
            if small == 2:
                break
        out = _evaluated(packed, x, args)
        if out is None:
            return x, False
        r, Jr = out[:nx], out[nx:].reshape(nx, nx, order="F")
        # each row in units of the unknowns (divided by its largest derivative): rows that go like
        # 1/α near α = 0 are then held to the rounding of the point, not of their size
        r = r / np.maximum(np.max(np.abs(Jr), axis=1), 1e-300)
        size = 1.0 + float(np.max(np.abs(x)))
        # (a root ``runaway`` times the start's size is not the step's: Newton can run to a far root of the friction
        # rows, whose rows hold relative to that size; docs/notes.md)
        return x, bool(np.max(np.abs(r)) <= self.o.step_tol * size and size <= self.o.runaway * size0)


def _evaluated(packed: ca.Function, x, args):
    """``packed(x, args)`` as a flat array, or None where CasADi's evaluation failed (the timed step's index-1 system
    singular at a trial point: dependent held rows, whose forces are not functions of the state)."""
    try:
        return packed(x, args).full().reshape(-1)
    except RuntimeError as exc:
        if "Evaluation failed" not in str(exc):
            raise
        return None


def _packed(fn: ca.Function) -> ca.Function:
    """``fn(x, *inputs) -> (r, J)`` as ``(x, P) -> [r; vec(J)]``, the inputs after ``x`` stacked in one vector ``P``
    (each column-major) and ``J`` dense: a call of two numeric inputs and one output."""
    ins = [ca.MX.sym(f"a{i}", fn.sparsity_in(i)) for i in range(fn.n_in())]
    sizes = [a.numel() for a in ins[1:]]
    P = ca.MX.sym("P", sum(sizes))
    parts = ca.vertsplit(P, np.concatenate([[0], np.cumsum(sizes)]).astype(int).tolist()) if sizes else []
    r, J = fn(ins[0], *[ca.reshape(part, a.shape) for part, a in zip(parts, ins[1:])])
    return ca.Function(f"{fn.name()}_packed", [ins[0], P], [ca.vertcat(ca.densify(r), ca.vec(ca.densify(J)))])


def _stage_line(cm: ContactMechanics, q, qs, qn):
    """The stages of both parts of a step on the straight lines ``q → q̃ → q_{k+1}`` (CasADi or numpy columns)."""
    if not cm.s:
        return ca.DM.zeros(0, 1) if not isinstance(q, np.ndarray) else np.zeros(0)
    ct = cm.dm.scheme.stage_times
    parts = [a + cj * (b - a) for a, b in ((q, qs), (qs, qn)) for cj in ct]
    return np.concatenate(parts) if isinstance(q, np.ndarray) else ca.vertcat(*parts)


def restage(cm: ContactMechanics, x, q):
    """``x`` with its stages on the straight lines of its sub-node and end node (a new start of Newton)."""
    if cm.s:
        n = cm.n
        x = x.copy()
        x[cm.layout["zs"]] = _stage_line(cm, np.asarray(q, float), x[:n], x[n:2 * n])
    return x
