"""``castrajectory control FILE.py``: an optimal-control problem the user describes in a file, solved whole
on the discrete action (DMOC) and certified, with the conventions of every scene (:func:`.scene.run_scene`).

The file is plain Python and defines ``problem()`` returning a :class:`castrajectory.OptimalControl`
(its system, horizon, boundary conditions, cost and path constraints), and optionally ``title`` and for
pictures ``exact_u(t)``, a closed-form control to draw beside the answer.  ``--n`` and ``--scheme``
override the grid and the scheme the file chose.

The file is loaded as a system file is (:func:`.system.load`: its folder on the import path, an exit refused).

Bad input is refused before any solve (exit 2, one line): a file that does not exist or does not import,
or exits while it loads, no ``problem()``, a ``problem()`` that does not return an ``OptimalControl`` or
raises (its message), a ``title`` that is not text, an ``exact_u`` that is not a function, a name that differs
from one of these only in case, and every refusal of the problem itself (boundary conditions of the wrong
length or off the constraints, a mass matrix that is not positive definite at the initial configuration, as
for a system file, bounds crossed, a cost that is not a scalar, a control in no force, a free-time interval
out of order).
"""
from __future__ import annotations

import sys
from typing import List, Optional

from ..validation import InputError, integer_at_least, one_of, quoted
from .scene import ArgumentParser, add_plot, check_animation_path, control_outcome, ipopt_options, run_scene
from .system import call_user, check_case, file_title, load

#: The names a control file may define for the command, each with the test of its kind.
KEYS = {"problem": callable, "title": lambda v: isinstance(v, str), "exact_u": callable}


def parser() -> ArgumentParser:
    from ..discretise.lagrangians import SCHEMES
    p = ArgumentParser(prog="castrajectory control",
                       description="Solve the optimal-control problem of FILE.py on the discrete action (DMOC).")
    p.add_argument("file", metavar="FILE.py", help="a Python file defining problem() -> ct.OptimalControl")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout and nothing else")
    p.add_argument("--verbose", action="store_true", help="stream Ipopt's log (to stderr with --json)")
    p.add_argument("--max-iter", type=int, default=None, help="Ipopt iterations")
    p.add_argument("--n", type=int, default=None, help="number of time steps N (default: the file's)")
    p.add_argument("--scheme", choices=list(SCHEMES), default=None, help="discrete Lagrangian (default: the file's)")
    add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def described(module, path: str):
    from ..solve.optimal_control import OptimalControl
    check_case(module, path, KEYS)
    return call_user(module, path, "problem", OptimalControl)


def run(args):
    check_animation_path(args.animate)
    module = load(args.file, defines="problem()")
    ocp = described(module, args.file)
    title = file_title(module, args.file)
    exact_u = getattr(module, "exact_u", None)
    if exact_u is not None and not callable(exact_u):
        raise InputError(f"{args.file}: exact_u must be a function of t (got {quoted(exact_u)})")
    if args.n is not None:
        ocp.N = integer_at_least("n", args.n, 2)
    if args.scheme is not None:
        ocp.scheme = one_of("scheme", args.scheme, (args.scheme,))
    sol = ocp.solve(options=ipopt_options(args), verbose=args.verbose)
    return control_outcome(title, ocp.system, sol, exact_u=exact_u)


def main(argv: Optional[List[str]] = None) -> int:
    return run_scene(parser(), run, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
