"""Command-line plumbing shared by the problem scripts, and the scene registry.

A problem script defines ``parser()`` and ``run(args) -> Outcome`` and calls
:func:`run_scene`, which applies the conventions of every scene:

* ``--json`` prints one JSON object on stdout and nothing else: while the
  scene runs, file descriptor 1 is pointed at stderr, so nothing a C++ library
  prints can leak into the JSON;
* exit code ``0`` solved, ``1`` the solver failed, or it converged and a check after it refused the
  answer (a pendant drop beyond its fold: no stable drop); the message on stderr says which,
  ``2`` bad input (one line on stderr, no traceback; output paths are checked before the solve),
  ``3`` solved and printed, but a requested file could not be written, ``130`` interrupted (SIGINT:
  one line, no traceback; :mod:`castrajectory.solve.interrupt` keeps a strategy from retrying), ``143``
  terminated (SIGTERM, the same);
* ``--plot`` / ``--animate`` files are written only after a successful solve and after its answer
  is printed, each to a temporary file renamed into place, so a refused, failed or interrupted run
  never overwrites or truncates earlier output.

The console command (``castrajectory list``, ``run``, ``report``) is :func:`castrajectory.cli.main`.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
import tempfile
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional

import numpy as np

from ..inspect.files import write_atomically
from ..solve import budget, interrupt
from ..result import SUCCESS_STATUSES, Result
from ..validation import InputError, cut
from .registry import scene_modules

#: Scene name -> module (the files in problems/, installed as castrajectory.problems): read from the
#: scene registry (:mod:`castrajectory.cli.registry`), where each scene is registered once.
SCENES = scene_modules()


class ArgumentParser(argparse.ArgumentParser):
    """argparse with a one-line error message and exit code 2."""

    def error(self, message):  # pragma: no cover - exercised through subprocess tests
        self.exit(2, f"{self.prog}: error: {message}\n")


def scene_parser(prog: str, description: str) -> ArgumentParser:
    p = ArgumentParser(prog=prog, description=description,
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout and nothing else")
    p.add_argument("--verbose", action="store_true", help="stream Ipopt's log (to stderr with --json)")
    p.add_argument("--max-iter", type=int, default=None,
                   help="solver iterations (Ipopt's, and Newton's on an initial-value system) of the whole run, "
                        "every sub-solve included (default: no cap)")
    return p


def ipopt_options(args) -> dict:
    """Ipopt options selected by the shared flags (``--max-iter`` at least 1)."""
    if args.max_iter is None:
        return {}
    if args.max_iter < 1:
        raise InputError(f"--max-iter must be at least 1 (got {args.max_iter})")
    return {"max_iter": args.max_iter}


def add_accuracy(p: argparse.ArgumentParser) -> None:
    """``--rtol`` and ``--n-max``: accuracy on request (the grid refined until the error estimate meets it)."""
    p.add_argument("--rtol", type=float, default=None,
                   help="refine n (powers of two) until the estimated relative error is at most this; "
                        "exit 1 if it cannot be reached")
    p.add_argument("--n-max", type=int, default=None,
                   help="largest n that --rtol may refine to (default 2^20, or what memory allows)")


def accuracy(args) -> dict:
    """``rtol`` and ``n_max`` from the flags of :func:`add_accuracy`, checked (exit 2 on bad values)."""
    rtol, n_max = getattr(args, "rtol", None), getattr(args, "n_max", None)
    if rtol is not None and not (math.isfinite(rtol) and 0.0 < rtol < 1.0):
        raise InputError(f"--rtol must be in (0, 1) (got {rtol})")
    if n_max is not None:
        if rtol is None:
            raise InputError("--n-max limits --rtol's refinement; give --rtol too")
        if n_max < args.n:
            raise InputError(f"--n-max must be at least --n = {args.n} (got {n_max})")
    return {"rtol": rtol, "n_max": n_max}


def finite_flags(args, *names: str) -> None:
    """Refuse a non-finite value of any of the flags ``names`` (attribute names; exit 2, one line)."""
    from ..validation import finite
    for name in names:
        finite("--" + name.replace("_", "-"), getattr(args, name))


def solve_trajectory(system, q0, qd0, args):
    """The scene's trajectory by the shared flags (``--T --n --scheme --method --rtol --n-max --max-iter
    --verbose``): :func:`castrajectory.solve.simulate.simulate`."""
    from ..solve import simulate
    return simulate.simulate(system, q0, qd0, args.T, args.n, args.scheme, args.method, options=ipopt_options(args),
                             verbose=args.verbose, **accuracy(args))


def add_control_flags(p: argparse.ArgumentParser, n: int, scheme: str = "midpoint") -> None:
    """Flags shared by the optimal-control scenes: grid, scheme, plot and animation (the horizon and the
    physics are each scene's own)."""
    p.add_argument("--n", type=int, default=n, help="number of time steps N (>= 2)")
    add_scheme(p, scheme, contact=False)
    p.add_argument("--controls", choices=("quadrature", "step"), default="quadrature",
                   help="controls at the scheme's quadrature nodes (its order) or one per step (order 2)")
    add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")


#: ``--scheme``'s help in a contact scene: what a scheme means where an impact splits a step.
CONTACT_SCHEME_HELP = "discrete Lagrangian (contact: each part of a step split at an impact carries the scheme's stages)"


def add_scheme(p: argparse.ArgumentParser, default: str = "midpoint", contact: bool = True) -> None:
    """``--scheme``: one of every registered discrete Lagrangian (:func:`castrajectory.schemes`), ``default``
    unless given; ``contact`` says in its help what a scheme does at an impact (the contact scenes).  A name
    that is not registered exits 2 with one line (argparse's ``invalid choice``)."""
    from ..discretise.schemes import SCHEMES
    p.add_argument("--scheme", choices=list(SCHEMES), default=default,
                   help=CONTACT_SCHEME_HELP if contact else "discrete Lagrangian")


def add_plot(p: argparse.ArgumentParser) -> None:
    p.add_argument("--plot", metavar="PATH", help="write a picture (format from the extension, e.g. .png, .pdf)")


def add_trajectory_flags(p: argparse.ArgumentParser, T: float, n: int, scheme: str = "midpoint",
                         methods: bool = True) -> None:
    """Flags shared by the mechanics scenes: horizon, grid, scheme, method, plot and animation."""
    from ..solve.simulate import METHODS
    p.add_argument("--T", type=float, default=T, help="duration T in s (> 0)")
    p.add_argument("--n", type=int, default=n, help="number of time steps N (>= 2)")
    add_scheme(p, scheme, contact=False)
    if methods:
        add_accuracy(p)
    if methods:
        p.add_argument("--method", choices=list(METHODS), default="whole",
                       help="whole: one whole-trajectory NLP (the library's method); others are baselines")
    add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")


def check_animation_path(path: Optional[str]) -> None:
    """Refuse an animation path we cannot write, before any work is done (exit 2)."""
    if not path:
        return
    ext = os.path.splitext(path)[1].lower()
    if ext not in (".gif", ".mp4"):
        raise InputError(f"--animate needs a .gif or .mp4 path (got {path!r})")
    if ext == ".mp4":
        from ..inspect import plotting
        if not plotting.mp4_available():
            raise InputError("--animate .mp4 needs ffmpeg, which was not found; use a .gif path")


def trajectory_outcome(title: str, system, run, extra: Optional[dict] = None,
                       extra_lines: Optional[List[str]] = None, links: bool = True) -> "Outcome":
    """Summary, JSON data and plot/animation writers of a mechanics scene."""
    from ..inspect import plotting
    e = np.asarray(run.energy, float)
    drift = float(np.max(np.abs(e - e[0]))) if e.size and np.all(np.isfinite(e)) else float("nan")
    rel = drift / max(abs(e[0]), 1e-300) if e.size else float("nan")
    names = list(system.names)
    final = ", ".join(f"{nm} = {v:.6g}" for nm, v in zip(names, run.q[-1]))
    how = f"method {run.method}" + (f", scheme {run.scheme}" if run.scheme else "")
    from ..solve.trajectory import work_of
    work = work_of(run)
    balance = work is not None and (system.forced or system.time_dependent)
    if balance:
        # forces or time dependence: the energy is not conserved, its balance is
        w = np.asarray(work, float)
        bal = float(np.max(np.abs(e - e[0] - w))) if np.all(np.isfinite(e)) else float("nan")
        energy_line = (f"energy: E(0) = {e[0]:.10g}, E(T) = {e[-1]:.10g}, work of forces and time dependence "
                       f"W(T) = {w[-1]:.10g}; balance max |E - E(0) - W| = {bal:.3e}")
    else:
        energy_line = f"energy: E(0) = {e[0]:.10g}, max |E - E(0)| = {drift:.3e} ({rel:.3e} relative)"
    lines = [f"{title}: {how}, N = {len(run.t) - 1}, T = {run.t[-1]:g} s",
             f"final state: {final}",
             energy_line,
             *(extra_lines or []),
             *interval_lines(system, run),
             status_line(run.status, run)]

    state = state_keys(system, run)
    extra = {**state, **(extra or {})}
    for name, vals in state.get("quantities", {}).items():
        vals = np.asarray(vals, float)
        lines.insert(-1, f"{name}: {vals[0]:.10g} at t = 0, max change {np.max(np.abs(vals - vals[0])):.3e}")

    def plot(path):
        if balance:  # forces or time dependence: the balance E − W, whose change is the error
            fig = plotting.energy_quantities_plot(run.t, {how: e - np.asarray(work, float)},
                                                  state.get("quantities", {}),
                                                  title=f"{title}: energy balance error |E − E₀ − W| / |E₀|")
        else:
            fig = plotting.energy_quantities_plot(run.t, {how: e}, state.get("quantities", {}),
                                                  title=f"{title}: energy error")
        fig.savefig(path)

    def animate(path):
        if system.points is None:
            raise InputError("this scene has no points to animate")
        plotting.animate_points(system.positions(run.q, run.t), run.t, path, links=links, title=title)

    return Outcome.of(run, extra, lines, writers={"plot": plot, "animate": animate})


def state_keys(system, run) -> dict:
    """The whole state of a mechanics answer for its JSON: velocities ``v`` and momenta ``p`` at the nodes
    (``p = ∂L/∂q̇``: for a variational answer the discrete momenta, whose Legendre transform ``v`` is), the
    system's declared ``quantities`` at every node, and for a contact answer its ``impacts`` -- one entry
    per contact and impact, so that every contact of a simultaneous impact is listed -- and its ``releases``
    (lift-offs, with the contact's name)."""
    t = np.asarray(run.t, float)
    q, v = np.asarray(run.q, float), np.asarray(run.v, float)
    out = {"v": v}
    p = getattr(run, "p", None)
    out["p"] = np.asarray(p if p is not None else system.momenta(q, v, t), float)
    if system.quantities:
        out["quantities"] = system.quantity_values(q, v, t)
    impacts = getattr(run, "impacts", None)
    if impacts is None:
        impacts = getattr(getattr(run, "detail", None), "impacts", None)
    if system.contact is not None and impacts is not None:
        names = system.contact.names
        # each impact as the solution records it (its contact's index, impulse mu, velocities), with the
        # contact's name and its impulse under that name
        out["impacts"] = [{**i.as_dict(), "name": names[i.contact], "impulse": float(i.mu)} for i in impacts]
        # the lift-offs (a contact that leaves without an impact of its own), per contact by name
        releases = getattr(run, "releases", None)
        if releases is None:
            releases = getattr(getattr(run, "detail", None), "releases", None)
        if releases is not None:
            out["releases"] = [{**r.as_dict(), "name": names[r.contact]} for r in releases]
        iv = contact_intervals(system, run)
        if iv is not None:
            out["contact_intervals"] = {name: [{"from": a, "to": b, "state": st} for a, b, st in pieces]
                                        for name, pieces in iv.items()}
    return out


def contact_intervals(system, run) -> Optional[dict]:
    """A contact answer's intervals of one state per contact, by the contact's name (``None`` for any other)."""
    iv = getattr(run, "intervals", None)
    if iv is None:
        iv = getattr(getattr(run, "detail", None), "intervals", None)
    if iv is None or system.contact is None:
        return None
    return dict(zip(system.contact.names, iv))


def interval_lines(system, run) -> List[str]:
    """One summary line per contact: its states over time, each with its interval (``contact floor: held 0–0.42 s,
    open 0.42–0.5 s``), at most eight intervals shown."""
    iv = contact_intervals(system, run)
    if not iv:
        return []
    out = []
    for name, pieces in iv.items():
        shown = ", ".join(f"{st} {a:.6g}–{b:.6g} s" for a, b, st in pieces[:8])
        more = f" (+{len(pieces) - 8} more)" if len(pieces) > 8 else ""
        out.append(f"contact {name}: {shown}{more}")
    return out


def control_outcome(title: str, system, sol, extra: Optional[dict] = None, extra_lines: Optional[List[str]] = None,
                    exact_u=None) -> "Outcome":
    """Summary, JSON data and plot/animation writers of an optimal-control scene (a
    :class:`~castrajectory.solve.optimal_control.ControlResult`)."""
    from ..inspect import plotting
    cert = "-" if not np.isfinite(sol.certificate) else f"{sol.certificate:.1e}"
    lines = [f"{title}: DMOC, scheme {sol.scheme}, N = {len(sol.t) - 1}, T = {sol.T:.10g} s",
             f"cost J = {sol.cost:.12g}; certificate (the controls marched, against the optimum) {cert}",
             *(extra_lines or []), status_line(sol.status, sol)]
    if hasattr(sol, "b_stationary") and np.isfinite(sol.b_violation):
        # (contact-implicit: the B-stationarity proxy, the multipliers of the pairs whose both factors vanish, and the
        # events held against their steps' windows, which no flip of a pair sees)
        why = ("none found" if sol.b_stationary else "events held at their windows' edges"
               if getattr(sol, "pinned", None) else "a descent by a flip")
        lines.insert(2, f"B-stationarity proxy: {sol.biactive} biactive pair(s), largest multiplier of a descent "
                        f"{sol.b_violation:.1e} ({why})")
    unames = [f"{c.name}[{i}]" if c.size > 1 else c.name for c in system.controls for i in range(c.size)]

    def plot(path):
        plotting.control_plot(sol.t, sol.q, system.names, sol.u, unames, title=title, exact_u=exact_u,
                              t_u=sol.t_u).savefig(path)

    def animate(path):
        if system.points is None:
            raise InputError("this scene has no points to animate")
        plotting.animate_points(system.positions(sol.q, sol.t), sol.t, path, links=True, title=title)

    return Outcome.of(sol, extra, lines, writers={"plot": plot, "animate": animate})


def friction_summary(system, tr, mu_f: float) -> dict:
    """With friction (``mu_f`` > 0): per bounce (not caught) the kinetic energy's relative change (never
    positive under Stronge's law), the tangential impulse against the cone (``|μ_t| − μ μ_n``, at most 0), and
    the frictional law applied to the bounce's own arrival against its outcome (one contact per impact; the
    planar law, or the tangent plane's); empty without friction."""
    import numpy as np
    from ..models.impact import frictional_impact, frictional_impact_plane
    if mu_f <= 0:
        return {}
    d = system.contact.slip_dim
    gains, cone, law = [], [], []
    for imp in tr.impacts:
        if imp.caught:
            continue
        M = np.asarray(system.mass_matrix(imp.q))
        K0, K1 = 0.5 * imp.v_before @ M @ imp.v_before, 0.5 * imp.v_after @ M @ imp.v_after
        gains.append((K1 - K0) / max(K0, 1e-300))
        cone.append(float(np.linalg.norm(np.atleast_1d(imp.mu_t))) - mu_f * imp.mu)
        if np.count_nonzero(tr.mu[imp.step] > 1e-9 * max(1.0, imp.mu)) == 1:
            D = np.asarray(system.tangent(imp.q)).reshape(system.ncontact, d, -1)[imp.contact]
            W = np.vstack([np.asarray(system.gap(imp.q)[1])[imp.contact], D])
            # Π: the inverse mass on the holonomic constraints' tangent space (M⁻¹ without constraints)
            Pi = np.linalg.inv(M)
            if system.nc:
                C = np.asarray(system.constraint(imp.q)[1])
                Pi = Pi - Pi @ C.T @ np.linalg.solve(C @ Pi @ C.T, C @ Pi)
            fn = frictional_impact if d == 1 else frictional_impact_plane
            P = fn(W @ Pi @ W.T, W @ imp.v_before, mu_f, system.contact.restitution).P
            law.append(float(np.max(np.abs(imp.v_before + Pi @ W.T @ P - imp.v_after))))
    return {"impact_energy_gain": max(gains) if gains else None, "friction_cone": max(cone) if cone else None,
            "frictional_law_error": max(law) if law else None}


def friction_lines(fr: dict) -> List[str]:
    """The summary line of :func:`friction_summary` (none without friction)."""
    if not fr:
        return []
    return [f"friction: largest relative kinetic-energy change at a bounce {fmt(fr['impact_energy_gain'], '.3g')} "
            f"(never positive), |μ_t| − μ μ_n at most {fmt(fr['friction_cone'], '.3g')}, "
            f"against the frictional law {fmt(fr['frictional_law_error'], '.3g')}"]


def contact_outcome(title: str, system, tr, data: dict, lines: List[str], ground=None,
                    series: Optional[dict] = None, ylabel: str = "height") -> "Outcome":
    """Outcome of a contact scene: summary lines, JSON data, a contact plot and an animation.

    ``series`` (label -> values per node) defaults to the smallest gap per node;
    ``ground`` is the polyline drawn under the animation.
    """
    from ..inspect import plotting
    lines = list(lines) + [
        f"lowest gap {min(tr.gap.min(), tr.gap_sub.min()):.2e}; complementarity residual "
        f"{tr.complementarity_residual:.1e}; energy {tr.energy[0]:.8g} -> {tr.energy[-1]:.8g}",
        f"relaxation (penalty) steps: {len(tr.homotopy)}; attempts: {len(tr.attempts)}",
        *interval_lines(system, tr),
        status_line(tr.status, tr)]

    def plot(path):
        ser = series if series is not None else {"smallest gap": tr.gap.min(axis=1)}
        # impulses per node (Λ_k, all contacts summed) at the node times; each contact's states over time
        fig = plotting.contact_plot(tr.t, ser, tr.t, tr.node_impulse.sum(axis=1), ylabel=ylabel, title=title,
                                    intervals=contact_intervals(system, tr))
        fig.savefig(path)

    def animate(path):
        plotting.animate_points(system.positions(tr.q), tr.t, path, links=True, pivot=None, trail=False,
                                ground=ground, title=title)

    # the JSON: the trajectory's as_dict() (with solver_status and message, which say how the answer
    # was reached, e.g. Rows_Verified), the whole state, the scene's keys on top
    return Outcome.of(tr, {**state_keys(system, tr), **data}, lines, writers={"plot": plot, "animate": animate})


@dataclass(kw_only=True)
class Outcome(Result):
    """What a scene's ``run`` returns: the contract of its answer, the JSON data, summary lines and writers.

    ``data`` is the scene's JSON object: its answer's ``as_dict()`` with the scene's own keys
    (oracle errors, the arrays it reports) on top (:meth:`of`).
    """

    data: dict = field(default_factory=dict)
    summary: List[str] = field(default_factory=list)
    writers: Dict[str, Callable[[str], None]] = field(default_factory=dict)  # flag name -> writer(path)

    @classmethod
    def of(cls, result: Result, data: Optional[dict] = None, summary=(), writers=None) -> "Outcome":
        """The outcome of a scene whose answer is ``result``: JSON ``result.as_dict()`` updated with ``data``."""
        return cls(**result.contract(), data={**result.as_dict(), **(data or {})}, summary=list(summary),
                   writers=dict(writers or {}))

    def as_dict(self) -> dict:
        return {**super().as_dict(), **self.data}


def jsonable(obj):
    """Convert numpy values and non-finite floats (-> None) so that ``json.dumps(allow_nan=False)`` works."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


@contextlib.contextmanager
def stdout_to_stderr(enabled: bool = True):
    """Point file descriptor 1 at stderr for the duration (catches output of C/C++ libraries too)."""
    if not enabled:
        yield
        return
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def check_output_path(flag: str, path: Optional[str]) -> None:
    """Refuse an output path before any work is done (exit 2): its folder must exist and be writable,
    and the path must not name a folder."""
    if not path:
        return
    folder = os.path.dirname(os.path.abspath(path)) or "."
    if os.path.isdir(path):
        raise InputError(f"--{flag} {path!r} is a folder; give a file path")
    if not os.path.isdir(folder):
        raise InputError(f"--{flag}: the folder {folder!r} does not exist")
    try:  # a real test: access() says yes to root in /proc
        fd, probe = tempfile.mkstemp(prefix=".castrajectory-probe.", dir=folder)
        os.close(fd)
        os.unlink(probe)
    except OSError:
        raise InputError(f"--{flag}: cannot write files in the folder {folder!r}") from None
    if not os.path.splitext(path)[1]:
        raise InputError(f"--{flag} {path!r} needs a file extension (the format is read from it)")
    if flag == "plot":
        from ..inspect.plotting import figure_formats
        ext = os.path.splitext(path)[1][1:].lower()
        if ext not in figure_formats():
            raise InputError(f"--plot {path!r}: no picture format .{ext} (one of: {', '.join(figure_formats())})")


#: Exit code of a run that was interrupted (SIGINT), as a shell reports it (SIGTERM: 143, ``interrupt.exit_code``).
EXIT_INTERRUPTED = 130
#: Exit code of a solved run whose answer was printed but a requested file could not be written.
EXIT_OUTPUT = 3
#: The longest line a refusal prints (characters).
MESSAGE_LIMIT = 1000


def _interrupted(exc: BaseException) -> bool:
    """A KeyboardInterrupt, or an error that CasADi raised while one was pending."""
    if interrupt.pending():
        return True
    while exc is not None:
        if isinstance(exc, KeyboardInterrupt) or "KeyboardInterrupt" in str(exc):
            return True
        exc = exc.__cause__ or exc.__context__
    return False


def run_scene(parser: argparse.ArgumentParser, run: Callable[[argparse.Namespace], Outcome],
              argv: Optional[List[str]] = None) -> int:
    """Parse, run, write outputs and return the exit code (see module docstring).

    The JSON printed is ``outcome.as_dict()``.  Output paths are checked before the solve; files are
    written after the answer is printed, each atomically.
    """
    args = parser.parse_args(argv)
    prog = parser.prog
    interrupt.install()       # SIGINT and SIGTERM: one line, temporaries removed, exit 130 or 143
    try:
        try:
            for flag in ("plot", "animate"):
                check_output_path(flag, getattr(args, flag, None))
            # --max-iter caps the Ipopt iterations of the whole run, every sub-solve included
            with stdout_to_stderr(args.json), budget.iterations(getattr(args, "max_iter", None)):
                outcome = run(args)
            # (a signal whose exception CasADi or a finaliser dropped after the last solve: measured, 3 of 25
            # SIGINTs into block_move at N = 20000 ran on to exit 0 with the answer)
            interrupt.check()
        except InputError as exc:
            # (one line, never the whole of a huge value that a message quoted: the last guard, the validation
            # helpers cut their own quotes to 80 characters)
            print(f"{prog}: error: {cut(str(exc), MESSAGE_LIMIT)}", file=sys.stderr)
            return 2
        if args.json:
            sys.stdout.write(json.dumps(jsonable(outcome.as_dict()), allow_nan=False) + "\n")
        else:
            print("\n".join(outcome.summary + estimate_lines(outcome) + [f"warning: {w}" for w in outcome.warnings]))
        sys.stdout.flush()
        if not outcome.success:
            # a converged solve whose answer a later check refused is no solver failure: the message says why
            failed = "" if outcome.solver_status in SUCCESS_STATUSES else "solver failed: "
            print(f"{prog}: {failed}{outcome.message}", file=sys.stderr)
            return 1
        for flag, writer in outcome.writers.items():
            path = getattr(args, flag, None)
            if path:
                try:
                    with stdout_to_stderr(args.json):
                        write_atomically(path, writer)
                except (InputError, OSError, ValueError, RuntimeError) as exc:
                    print(f"{prog}: could not write --{flag} {path}: {exc}", file=sys.stderr)
                    return EXIT_OUTPUT
    except BaseException as exc:  # an interrupt, also when CasADi wrapped it: one line, exit 130 (143: SIGTERM)
        if not _interrupted(exc) or isinstance(exc, SystemExit):
            raise
        print(f"{prog}: {interrupt.what()}", file=sys.stderr)
        return interrupt.exit_code()
    return 0


def estimate_lines(result) -> List[str]:
    """The summary line of the answer's error estimate (none for a result without one)."""
    est = getattr(result, "error_estimate", None)
    return [] if est is None or not result.success else [est.line()]


def status_line(status: str, result) -> str:
    """The closing line of every summary: status, the solver's message, iterations (Ipopt's, and Newton's on an
    initial-value system) and wall times."""
    return (f"status: {status} ({result.message}); {result.iterations} solver iterations; "
            f"build {result.build_time_s:.3f} s, solve {result.solve_time_s:.4f} s")


def fmt(v, spec: str = ".10g") -> str:
    return "-" if v is None else format(v, spec)


def table(rows: List[List[str]]) -> List[str]:
    """Left-aligned plain-text table."""
    widths = [max(len(str(r[i])) for r in rows) for i in range(len(rows[0]))]
    return ["  ".join(str(c).ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
