"""``castrajectory system FILE.py``: a system the user describes in a file, solved as one whole-trajectory
stationary-action problem, with the conventions of every scene (:func:`.scene.run_scene`).

The file is plain Python and defines:

* ``system()`` returning a :class:`castrajectory.LagrangianSystem` built from the public API;
* ``q0`` and ``qd0``, the initial coordinates and velocities;
* optionally ``T`` and ``n`` (the flags override them), ``title``, and for pictures ``links``:
  ``True`` (the atoms joined in order from the origin), ``False``, or pairs ``(i, j)`` of atom indices
  to join by lines (``-1``: the origin), e.g. ``[(-1, 0), (0, 1)]``.

Bad input is refused before any solve (exit 2, one line): a file that does not exist or does not
import, no ``system()``, a ``system()`` that does not return a ``LagrangianSystem``, ``q0`` / ``qd0`` of
the wrong length or not finite, a mass matrix that is not positive definite at ``q0`` (naming the
coordinate without inertia), initial conditions off the holonomic constraints.
"""
from __future__ import annotations

import importlib.util
import os
import sys
from typing import List, Optional

import numpy as np

from ..validation import InputError, state_vector
from .scene import (ArgumentParser, accuracy, add_trajectory_flags, check_animation_path, ipopt_options, run_scene,
                    trajectory_outcome)

#: Horizon and steps when neither the file nor the flags give them.
DEFAULT_T, DEFAULT_N = 5.0, 1000


def parser() -> ArgumentParser:
    p = ArgumentParser(prog="castrajectory system",
                       description="Solve the system described in FILE.py as one whole-trajectory NLP.")
    p.add_argument("file", metavar="FILE.py", help="a Python file defining system(), q0, qd0 (T, n optional)")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout and nothing else")
    p.add_argument("--verbose", action="store_true", help="stream Ipopt's log (to stderr with --json)")
    p.add_argument("--max-iter", type=int, default=None, help="Ipopt iterations of the whole run")
    add_trajectory_flags(p, T=None, n=None)
    p.add_argument("--derive", metavar="PATH", help="also write the system's derivation (Markdown, LaTeX math)")
    return p


def load(path: str):
    """Import the user's file as a module (``InputError`` with one line if it cannot be)."""
    if not os.path.isfile(path):
        raise InputError(f"{path}: no such file")
    name = "castrajectory_user_" + "".join(c if c.isalnum() else "_" for c in os.path.splitext(os.path.basename(path))[0])
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise InputError(f"{path}: not a Python file")
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - whatever the user's file raises is bad input
        raise InputError(f"{path} does not import: {type(exc).__name__}: {exc}".splitlines()[0]) from None
    return module


def call_user(module, path: str, name: str, kind: type):
    """The value of the user's ``name()``, which must be a ``kind`` (``InputError`` with one line otherwise: no
    such function, whatever it raises, or a value of another type)."""
    fn = getattr(module, name, None)
    if not callable(fn):
        raise InputError(f"{path} defines no {name}() function")
    try:
        value = fn()
    except InputError as exc:
        raise InputError(f"{path}: {name}(): {exc}") from None
    except Exception as exc:  # noqa: BLE001 - whatever the user's file raises is bad input
        raise InputError(f"{path}: {name}() raised {type(exc).__name__}: {exc}".splitlines()[0]) from None
    if not isinstance(value, kind):
        raise InputError(f"{path}: {name}() returned a {type(value).__name__}, not a castrajectory.{kind.__name__}")
    return value


def described(module, path: str):
    """``(system, q0, qd0)`` from the user's module, checked (see the module docstring)."""
    from ..models.mechanics import LagrangianSystem

    system = call_user(module, path, "system", LagrangianSystem)
    from ..solve.trajectory import check_inertia
    vectors = []
    for name in ("q0", "qd0"):
        if not hasattr(module, name):
            raise InputError(f"{path} defines no {name}")
        try:
            vectors.append(state_vector(name, getattr(module, name), system.nq, system.names))
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
    q0, qd0 = vectors
    try:
        check_inertia(system, q0)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    if system.nc:
        c, C = (np.asarray(x, float) for x in system.constraint(q0, 0.0))
        cv = C @ qd0 + np.asarray(system.constraint_rate(q0, 0.0), float).reshape(-1)
        if np.max(np.abs(c), initial=0.0) > 1e-9 or np.max(np.abs(cv), initial=0.0) > 1e-9:
            raise InputError(f"{path}: q0, qd0 violate the holonomic constraints (|c(q0)| = "
                             f"{np.max(np.abs(c)):.3g}, |C(q0) qd0 + dc/dt| = {np.max(np.abs(cv)):.3g})")
    return system, q0, qd0


def run(args):
    check_animation_path(args.animate)
    if args.derive:
        from .scene import check_output_path
        check_output_path("derive", args.derive)
    module = load(args.file)
    system, q0, qd0 = described(module, args.file)
    T = args.T if args.T is not None else float(getattr(module, "T", DEFAULT_T))
    n = args.n if args.n is not None else int(getattr(module, "n", DEFAULT_N))
    args.T, args.n = T, n
    from ..solve import simulate
    res = simulate.simulate(system, q0, qd0, T, n, args.scheme, args.method, options=ipopt_options(args),
                            verbose=args.verbose, **accuracy(args))
    title = str(getattr(module, "title", os.path.splitext(os.path.basename(args.file))[0]))
    links = getattr(module, "links", True)
    out = trajectory_outcome(title, system, res, links=links if isinstance(links, bool) else list(links))

    def derive(path):
        from ..inspect import derivation
        with open(path, "w") as fh:
            fh.write(derivation.markdown(system, title, args.scheme))
    out.writers["derive"] = derive
    return out


def main(argv: Optional[List[str]] = None) -> int:
    return run_scene(parser(), run, argv)


def derive_parser() -> ArgumentParser:
    p = ArgumentParser(prog="castrajectory derive",
                       description="Write the derivation of the system in FILE.py (Markdown with LaTeX math).")
    p.add_argument("file", metavar="FILE.py", help="a Python file defining system(), q0, qd0")
    p.add_argument("--out", required=True, metavar="PATH", help="the Markdown file to write (e.g. derivation.md)")
    from ..discretise.lagrangians import SCHEMES
    p.add_argument("--scheme", choices=list(SCHEMES), default="midpoint", help="the discrete Lagrangian described")
    return p


def derive_main(argv: Optional[List[str]] = None) -> int:
    """``castrajectory derive FILE.py --out derivation.md``: exit 0 written, 2 bad input (one line)."""
    from ..inspect import derivation, files
    from .scene import check_output_path
    args = derive_parser().parse_args(argv)
    try:
        check_output_path("out", args.out)
        module = load(args.file)
        system, _, _ = described(module, args.file)
        title = str(getattr(module, "title", os.path.splitext(os.path.basename(args.file))[0]))
        text = derivation.markdown(system, title, args.scheme)
    except InputError as exc:
        print(f"castrajectory derive: error: {exc}", file=sys.stderr)
        return 2
    files.write_text(args.out, text)
    print(f"derivation written to {args.out}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
