"""The command line: problem-script plumbing (:mod:`.scene`), the scene registry, the console command.

``castrajectory list``, ``castrajectory run <scene> [flags]``, ``castrajectory system FILE.py [flags]``
(:mod:`.system`: a system the user describes) and ``castrajectory report --out DIR`` (:mod:`.report`).  Problem scripts use the plumbing re-exported here (``cli.run_scene``, ...).
"""
from __future__ import annotations

import importlib
import os
import sys
from typing import List, Optional

from .scene import (
    SCENES, ArgumentParser, Outcome, accuracy, add_accuracy, add_control_flags, add_plot, add_scheme,
    add_trajectory_flags,
    check_animation_path, contact_intervals, contact_outcome, control_outcome, finite_flags, fmt, friction_lines,
    friction_summary, interval_lines, ipopt_options, jsonable, run_scene, scene_parser, solve_trajectory, state_keys,
    status_line, stdout_to_stderr, table, trajectory_outcome)

#: The problem scripts' plumbing, re-exported from :mod:`.scene`, and the console command.
__all__ = ["SCENES", "ArgumentParser", "Outcome", "accuracy", "add_accuracy", "add_control_flags", "add_plot",
           "add_scheme", "add_trajectory_flags", "check_animation_path", "contact_intervals", "contact_outcome",
           "control_outcome", "finite_flags", "fmt", "friction_lines", "friction_summary", "interval_lines",
           "ipopt_options", "jsonable", "run_scene", "state_keys",
           "scene_parser", "solve_trajectory", "status_line",
           "stdout_to_stderr", "table", "trajectory_outcome", "main"]


def main(argv: Optional[List[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    p = ArgumentParser(prog="castrajectory", description="Variational mechanics as NLPs (CasADi + Ipopt).")
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the scenes")
    r = sub.add_parser("run", help="run a scene: castrajectory run <scene> [scene flags]", add_help=False)
    r.add_argument("scene")
    rep = sub.add_parser("report", help="solve every scene at its defaults and write a report")
    rep.add_argument("--out", required=True, metavar="DIR", help="output directory")
    size = rep.add_mutually_exclusive_group()
    size.add_argument("--quick", action="store_true", help="the smallest sweeps (for tests: N up to 2048)")
    size.add_argument("--full", action="store_true", help="the larger sweeps (droplet to N = 1e5, pendulum to 16000)")
    rep.add_argument("--quiet", action="store_true", help="no progress lines")
    rep.add_argument("--jobs", type=int, default=None, metavar="J",
                     help="processes that run the report's sections (default: one per core; 1: in this process)")
    sub.add_parser("system", help="solve the system described in FILE.py: castrajectory system FILE.py [flags]",
                   add_help=False)
    sub.add_parser("derive", help="write the derivation of FILE.py: castrajectory derive FILE.py --out PATH",
                   add_help=False)
    sub.add_parser("control", help="solve the optimal-control problem of FILE.py: castrajectory control FILE.py "
                                   "[flags]", add_help=False)
    if argv[:1] == ["control"]:
        from . import control
        return control.main(argv[1:])
    if argv[:1] == ["system"]:
        from . import system
        return system.main(argv[1:])
    if argv[:1] == ["derive"]:
        from . import system
        return system.derive_main(argv[1:])
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
    from .scene import _interrupted
    if args.jobs is not None and args.jobs < 1:
        print("castrajectory report: error: --jobs must be at least 1", file=sys.stderr)
        return 2
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        print(f"castrajectory report: error: --out {args.out} is a file, not a folder", file=sys.stderr)
        return 2
    try:
        return write_report(args.out, size="quick" if args.quick else "full" if args.full else "default",
                            quiet=args.quiet, jobs=args.jobs)
    except BaseException as exc:  # Ctrl-C: the report stops, files already written stay as they are
        if isinstance(exc, SystemExit) or not _interrupted(exc):
            raise
        from ..solve import interrupt
        print(f"castrajectory report: {interrupt.what()}", file=sys.stderr)
        return interrupt.exit_code()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
