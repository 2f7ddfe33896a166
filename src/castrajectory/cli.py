"""Command-line plumbing shared by the problem scripts, and the ``castrajectory`` console command.

A problem script defines ``parser()`` and ``run(args) -> Outcome`` and calls
:func:`run_scene`, which applies the conventions of every scene:

* ``--json`` prints one JSON object on stdout and nothing else: while the
  scene runs, file descriptor 1 is pointed at stderr, so nothing a C++ library
  prints can leak into the JSON;
* exit code ``0`` solved, ``1`` the solver failed (message on stderr),
  ``2`` bad input (one line on stderr, no traceback);
* ``--plot`` / ``--animate`` files are written only after a successful solve,
  so a refused or failed run never overwrites earlier output.

Console: ``castrajectory list``, ``castrajectory run <scene> [flags]``,
``castrajectory report --out DIR``.
"""
from __future__ import annotations

import argparse
import contextlib
import importlib
import json
import math
import os
import sys
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional

import numpy as np

from .validation import InputError

#: Scene name -> module (the files in problems/, installed as castrajectory.problems).
SCENES = {
    "droplet": "castrajectory.problems.droplet",
    "droplet_angle": "castrajectory.problems.droplet_angle",
    "double_pendulum": "castrajectory.problems.double_pendulum",
    "n_link_pendulum": "castrajectory.problems.n_link_pendulum",
    "stiff_spring_pendulum": "castrajectory.problems.stiff_spring_pendulum",
    "thrown_ball": "castrajectory.problems.thrown_ball",
    "collision_impulse": "castrajectory.problems.collision_impulse",
    "bouncing_ball": "castrajectory.problems.bouncing_ball",
    "rectangle_drop": "castrajectory.problems.rectangle_drop",
    "bowl": "castrajectory.problems.bowl",
}


class ArgumentParser(argparse.ArgumentParser):
    """argparse with a one-line error message and exit code 2."""

    def error(self, message):  # pragma: no cover - exercised through subprocess tests
        self.exit(2, f"{self.prog}: error: {message}\n")


def scene_parser(prog: str, description: str) -> ArgumentParser:
    p = ArgumentParser(prog=prog, description=description,
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout and nothing else")
    p.add_argument("--verbose", action="store_true", help="stream Ipopt's log (to stderr with --json)")
    p.add_argument("--max-iter", type=int, default=None, help="Ipopt iteration limit (default: library's)")
    return p


def ipopt_options(args) -> dict:
    """Ipopt options selected by the shared flags."""
    return {} if args.max_iter is None else {"max_iter": args.max_iter}


def add_plot(p: argparse.ArgumentParser) -> None:
    p.add_argument("--plot", metavar="PATH", help="write a picture (format from the extension, e.g. .png, .pdf)")


def add_trajectory_flags(p: argparse.ArgumentParser, T: float, n: int, scheme: str = "midpoint",
                         methods: bool = True) -> None:
    """Flags shared by the mechanics scenes: horizon, grid, scheme, method, plot and animation."""
    from .discrete import SCHEMES
    from .simulate import METHODS
    p.add_argument("--T", type=float, default=T, help="duration T in s (> 0)")
    p.add_argument("--n", type=int, default=n, help="number of time steps N (>= 2)")
    p.add_argument("--scheme", choices=list(SCHEMES), default=scheme, help="discrete Lagrangian")
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
        from matplotlib.animation import FFMpegWriter
        if not FFMpegWriter.isAvailable():
            raise InputError("--animate .mp4 needs ffmpeg, which was not found; use a .gif path")


def trajectory_outcome(title: str, system, run, extra: Optional[dict] = None,
                       extra_lines: Optional[List[str]] = None, links: bool = True) -> "Outcome":
    """Summary, JSON data and plot/animation writers of a mechanics scene."""
    from . import plotting
    e = np.asarray(run.energy, float)
    drift = float(np.max(np.abs(e - e[0]))) if e.size and np.all(np.isfinite(e)) else float("nan")
    rel = drift / max(abs(e[0]), 1e-300) if e.size else float("nan")
    names = list(system.names)
    final = ", ".join(f"{nm} = {v:.6g}" for nm, v in zip(names, run.q[-1]))
    how = f"method {run.method}" + (f", scheme {run.scheme}" if run.scheme else "")
    lines = [f"{title}: {how}, N = {len(run.t) - 1}, T = {run.t[-1]:g} s",
             f"final state: {final}",
             f"energy: E(0) = {e[0]:.10g}, max |E - E(0)| = {drift:.3e} ({rel:.3e} relative)",
             *(extra_lines or []),
             status_line(run.status, run)]
    data = run.as_dict()
    data.update(extra or {})

    def plot(path):
        fig = plotting.energy_plot(run.t, {how: e}, title=f"{title}: energy error")
        fig.savefig(path)

    def animate(path):
        if system.points is None:
            raise InputError("this scene has no points to animate")
        plotting.animate_points(system.positions(run.q), run.t, path, links=links, title=title)

    return Outcome(run.success, data, lines, run.message, writers={"plot": plot, "animate": animate})


def contact_outcome(title: str, system, tr, data: dict, lines: List[str], ground=None,
                    series: Optional[dict] = None, ylabel: str = "height") -> "Outcome":
    """Outcome of a contact scene: summary lines, JSON data, a contact plot and an animation.

    ``series`` (label -> values per node) defaults to the smallest gap per node;
    ``ground`` is the polyline drawn under the animation.
    """
    from . import plotting
    status = "ok" if tr.success else tr.status
    lines = list(lines) + [
        f"lowest gap {min(tr.gap.min(), tr.gap_sub.min()):.2e}; complementarity residual "
        f"{tr.complementarity_residual:.1e}; energy {tr.energy[0]:.8g} -> {tr.energy[-1]:.8g}",
        f"relaxation (penalty) steps: {len(tr.homotopy)}; attempts: {len(tr.attempts)}",
        status_line(status, tr)]
    # solver_status and message say how the answer was reached (e.g. Assembled_From_Windows: every
    # horizon window converged and the assembled point satisfies the whole NLP; see contact.py)
    data = {"status": status, "solver_status": tr.status, "message": tr.message,
            "iterations": tr.iterations, "build_time_s": tr.build_time_s,
            "solve_time_s": tr.solve_time_s, **data,
            "complementarity_residual": tr.complementarity_residual,
            "homotopy": [vars(s) for s in tr.homotopy], "attempts": tr.attempts}

    def plot(path):
        ser = series if series is not None else {"smallest gap": tr.gap.min(axis=1)}
        # impulses per node (Λ_k, all contacts summed) at the node times
        fig = plotting.contact_plot(tr.t, ser, tr.t, tr.node_impulse.sum(axis=1), ylabel=ylabel, title=title)
        fig.savefig(path)

    def animate(path):
        plotting.animate_points(system.positions(tr.q), tr.t, path, links=True, pivot=None, trail=False,
                                ground=ground, title=title)

    return Outcome(tr.success, data, lines, tr.message, writers={"plot": plot, "animate": animate})


@dataclass
class Outcome:
    """What a scene's ``run`` returns."""

    success: bool
    data: dict
    summary: List[str]
    message: str = ""
    writers: Dict[str, Callable[[str], None]] = field(default_factory=dict)  # flag name -> writer(path)


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


def run_scene(parser: argparse.ArgumentParser, run: Callable[[argparse.Namespace], Outcome],
              argv: Optional[List[str]] = None) -> int:
    """Parse, run, write outputs and return the exit code (see module docstring)."""
    args = parser.parse_args(argv)
    prog = parser.prog
    try:
        with stdout_to_stderr(args.json):
            outcome = run(args)
            if outcome.success:
                for flag, writer in outcome.writers.items():
                    path = getattr(args, flag, None)
                    if path:
                        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
                        writer(path)
    except InputError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        sys.stdout.write(json.dumps(jsonable(outcome.data), allow_nan=False) + "\n")
    else:
        print("\n".join(outcome.summary))
    if not outcome.success:
        print(f"{prog}: solver failed: {outcome.message}", file=sys.stderr)
        return 1
    return 0


def status_line(status: str, result) -> str:
    """The closing line of every summary: status, Ipopt message, iterations and wall times."""
    return (f"status: {status} ({result.message}); {result.iterations} Ipopt iterations; "
            f"build {result.build_time_s:.3f} s, solve {result.solve_time_s:.4f} s")


def fmt(v, spec: str = ".10g") -> str:
    return "-" if v is None else format(v, spec)


def table(rows: List[List[str]]) -> List[str]:
    """Left-aligned plain-text table."""
    widths = [max(len(str(r[i])) for r in rows) for i in range(len(rows[0]))]
    return ["  ".join(str(c).ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]


# ---------------------------------------------------------------------------- console command
def main(argv: Optional[List[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    p = ArgumentParser(prog="castrajectory", description="Variational mechanics as NLPs (CasADi + Ipopt).")
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the scenes")
    r = sub.add_parser("run", help="run a scene: castrajectory run <scene> [scene flags]", add_help=False)
    r.add_argument("scene")
    rep = sub.add_parser("report", help="solve every scene at its defaults and write a report")
    rep.add_argument("--out", required=True, metavar="DIR", help="output directory")
    rep.add_argument("--quick", action="store_true", help="smaller convergence sweep (N up to 2048)")
    if argv[:1] == ["run"]:
        if len(argv) < 2 or argv[1].startswith("-"):
            print("castrajectory: error: run needs a scene name; see `castrajectory list`", file=sys.stderr)
            return 2
        name = argv[1]
        if name not in SCENES:
            print(f"castrajectory: error: unknown scene {name!r}; known: {', '.join(SCENES)}", file=sys.stderr)
            return 2
        return importlib.import_module(SCENES[name]).main(argv[2:])
    args = p.parse_args(argv)
    if args.command == "list":
        for name, mod in SCENES.items():
            doc = (importlib.import_module(mod).__doc__ or "").strip().splitlines()
            print(f"{name:16s} {doc[0] if doc else ''}")
        return 0
    from .report import write_report
    return write_report(args.out, quick=args.quick)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
