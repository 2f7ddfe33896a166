"""``castrajectory system FILE.py``: a system the user describes in a file, solved as one whole-trajectory
stationary-action problem, with the conventions of every scene (:func:`.scene.run_scene`).

The file is plain Python and defines:

* ``system()`` returning a :class:`castrajectory.LagrangianSystem` built from the public API;
* ``q0`` and ``qd0``, the initial coordinates and velocities;
* optionally ``T`` and ``n`` (the flags override them), ``title``, and for pictures ``links``:
  ``True`` (the atoms joined in order from the origin), ``False``, or pairs ``(i, j)`` of atom indices
  to join by lines (``-1``: the origin), e.g. ``[(-1, 0), (0, 1)]``.

The file runs as Python runs a script: its folder is first on the import path while it loads (and while
``system()`` runs), so it may import a module of its own beside it.

Bad input is refused before any solve (exit 2, one line): a file that does not exist or does not
import, or that exits (``sys.exit``) while it loads, no ``system()``, a ``system()`` that does not return a
``LagrangianSystem``, ``q0`` / ``qd0`` of the wrong length or not finite, a mass matrix that is not positive
definite at ``q0`` (naming the coordinate without inertia), initial conditions off the holonomic constraints,
a ``T`` that is not a positive number, an ``n`` that is not an integer >= 2 (``200.0`` is one, ``200.7`` is
not), a ``title`` that is not text, ``links`` that are neither ``True``, ``False`` nor pairs of atom indices,
and a name that differs from one of these only in case (``N = 200`` for ``n``: it would be ignored).
"""
from __future__ import annotations

import contextlib
import importlib.util
import os
import sys
from typing import List, Optional

import numpy as np

from ..validation import InputError, cut, integer_at_least, positive, quoted, state_vector
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
    p.add_argument("--max-iter", type=int, default=None, help="solver iterations (Ipopt's and Newton's) of the whole run")
    add_trajectory_flags(p, T=None, n=None)
    p.add_argument("--derive", metavar="PATH", help="also write the system's derivation (Markdown, LaTeX math)")
    return p


#: The longest excerpt of a user's own exception that a message quotes.
EXCEPTION_EXCERPT = 160


@contextlib.contextmanager
def beside(path: str):
    """The folder of ``path`` first on ``sys.path`` while the block runs, as Python puts a script's folder there
    (a system file may import a module of its own beside it); taken away afterwards."""
    folder = os.path.dirname(os.path.abspath(path))
    sys.path.insert(0, folder)
    try:
        yield
    finally:
        try:
            sys.path.remove(folder)  # the first entry equal to it: ours, unless the file put one before it
        except ValueError:
            pass


def _exited(exc: SystemExit) -> str:
    return f"sys.exit({'' if exc.code is None else quoted(exc.code)})"


def load(path: str, defines: str = "system()"):
    """Import the user's file as a module (``InputError`` with one line if it cannot be, or if it exits)."""
    if not os.path.isfile(path):
        raise InputError(f"{path}: no such file")
    name = "castrajectory_user_" + "".join(c if c.isalnum() else "_" for c in os.path.splitext(os.path.basename(path))[0])
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise InputError(f"{path}: not a Python file")
    module = importlib.util.module_from_spec(spec)
    try:
        with beside(path):
            spec.loader.exec_module(module)
    except InputError as exc:
        raise InputError(f"{path}: {cut(exc, EXCEPTION_EXCERPT)}") from None
    except SystemExit as exc:  # a script's habit; the file is read for what it defines
        raise InputError(f"{path} called {_exited(exc)} while loading; it must define {defines}, not exit") from None
    except Exception as exc:  # noqa: BLE001 - whatever the user's file raises is bad input
        raise InputError(f"{path} does not import: {type(exc).__name__}: {cut(exc, EXCEPTION_EXCERPT)}") from None
    return module


def call_user(module, path: str, name: str, kind: type):
    """The value of the user's ``name()``, which must be a ``kind`` (``InputError`` with one line otherwise: no
    such function, whatever it raises, an exit, or a value of another type)."""
    fn = getattr(module, name, None)
    if not callable(fn):
        raise InputError(f"{path} defines no {name}() function")
    try:
        with beside(path):
            value = fn()
    except InputError as exc:
        raise InputError(f"{path}: {name}(): {cut(exc, EXCEPTION_EXCERPT)}") from None
    except SystemExit as exc:
        raise InputError(f"{path}: {name}() called {_exited(exc)}; it must return a castrajectory.{kind.__name__}") \
            from None
    except Exception as exc:  # noqa: BLE001 - whatever the user's file raises is bad input
        raise InputError(f"{path}: {name}() raised {type(exc).__name__}: {cut(exc, EXCEPTION_EXCERPT)}") from None
    if not isinstance(value, kind):
        raise InputError(f"{path}: {name}() returned a {type(value).__name__}, not a castrajectory.{kind.__name__}")
    return value


def check_case(module, path: str, keys) -> None:
    """Refuse a name that differs from a key the file may define only in case, where the key itself is missing
    and the name's value is of the key's kind (``N = 200`` was ignored, and the run took the default 1000 steps;
    ``t = ct.time()`` is no horizon).  ``keys`` maps each key to the test of its kind."""
    for key, kind in keys.items():
        if not hasattr(module, key):
            near = [k for k in vars(module) if k != key and k.lower() == key.lower() and kind(vars(module)[k])]
            if near:
                raise InputError(f"{path} defines {near[0]} but no {key}: did you mean {key}? (rename it, or "
                                 f"define {key} as well)")


def is_number(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def is_sequence(value) -> bool:
    return isinstance(value, (list, tuple, np.ndarray))


def described(module, path: str):
    """``(system, q0, qd0)`` from the user's module, checked (see the module docstring)."""
    from ..models.mechanics import LagrangianSystem

    check_case(module, path, KEYS)
    system = call_user(module, path, "system", LagrangianSystem)
    vectors = []
    for name in ("q0", "qd0"):
        if not hasattr(module, name):
            raise InputError(f"{path} defines no {name}")
        try:
            vectors.append(state_vector(name, getattr(module, name), system.nq, system.names))
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
    q0, qd0 = vectors
    from ..solve.trajectory import check_inertia
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


#: The names a system file may define for the command, each with the test of its kind (the rest of the file is
#: the user's own).
KEYS = {"system": callable, "q0": is_sequence, "qd0": is_sequence, "T": is_number, "n": is_number,
        "title": lambda v: isinstance(v, str), "links": lambda v: isinstance(v, bool) or is_sequence(v)}


def settings(module, path: str, system):
    """``(T, n, title, links)`` from the user's module, each checked (the defaults where it gives none): the
    horizon a positive number, the steps an integer >= 2, the title text, the links ``True``, ``False`` or pairs
    ``(i, j)`` of atom indices (``-1``: the origin)."""
    try:
        T = positive("T", getattr(module, "T", DEFAULT_T))
        n = integer_at_least("n", getattr(module, "n", DEFAULT_N), 2)
        links = picture_links(getattr(module, "links", True), len(system.points_expr or ()))
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    return T, n, file_title(module, path), links


def file_title(module, path: str) -> str:
    """The file's ``title``, which must be text; the file's name without it."""
    title = getattr(module, "title", os.path.splitext(os.path.basename(path))[0])
    if not isinstance(title, str):
        raise InputError(f"{path}: title must be text (got {quoted(title)})")
    return title


def picture_links(value, points: int):
    """``links`` checked: ``True`` or ``False``, or a list of pairs ``(i, j)`` of point indices in
    ``[-1, points)`` (``-1``: the origin)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, np.ndarray):
        value = value.tolist()
    why = (f"links must be True, False or pairs (i, j) of atom indices from -1 (the origin) to {points - 1} "
           f"(got {quoted(value)})" if points else
           f"links must be True or False: the system has no atoms to join (got {quoted(value)})")
    if not isinstance(value, (list, tuple)):
        raise InputError(why)
    pairs = []
    for pair in value:
        if not (isinstance(pair, (list, tuple)) and len(pair) == 2
                and all(isinstance(k, (int, np.integer)) and not isinstance(k, (bool, np.bool_)) for k in pair)
                and all(-1 <= k < points for k in pair)):
            raise InputError(why)
        pairs.append((int(pair[0]), int(pair[1])))
    return pairs


def run(args):
    check_animation_path(args.animate)
    if args.derive:
        from .scene import check_output_path
        check_output_path("derive", args.derive)
    module = load(args.file)
    system, q0, qd0 = described(module, args.file)
    T, n, title, links = settings(module, args.file, system)
    T = args.T if args.T is not None else T
    n = args.n if args.n is not None else n
    args.T, args.n = T, n
    from ..solve import simulate
    res = simulate.simulate(system, q0, qd0, T, n, args.scheme, args.method, options=ipopt_options(args),
                            verbose=args.verbose, **accuracy(args))
    out = trajectory_outcome(title, system, res, links=links)

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
        _, _, title, _ = settings(module, args.file, system)
        text = derivation.markdown(system, title, args.scheme)
    except InputError as exc:
        print(f"castrajectory derive: error: {exc}", file=sys.stderr)
        return 2
    files.write_text(args.out, text)
    print(f"derivation written to {args.out}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
