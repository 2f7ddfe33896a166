"""The report's generated derivations of the built-in mechanics scenes.

They are written by a child process with a time limit, tried twice: sympy's ``simplify`` takes its heuristics in an
order that depends on the process (its sets of expressions are ordered by hashes), and about one process in sixty
spent minutes in ``trigsimp`` on the 4-link pendulum's kinetic energy, where every other one took 2.5 s.  A fresh
process is a fresh order; the report never waits on one unlucky one.
"""
from __future__ import annotations

import os
import subprocess
import sys

from ...inspect import files
from .common import Context

TITLE = 'generated derivations'
TIMED = True

#: seconds one try may take (the four take about 6 s together), and the tries
LIMIT_S, TRIES = 90.0, 2


def _scenes():
    """``(file stem, title, system builder)`` of each scene."""
    from ...models import pendulum, rigidbody
    return [("double_pendulum", "double pendulum", pendulum.double_pendulum),
            ("n_link_pendulum", "4-link pendulum", lambda: pendulum.n_link_pendulum([1.0] * 4, [1.0] * 4, 9.81)),
            ("stiff_spring_pendulum", "spring pendulum (k l/(m g) = 1e4)",
             lambda: pendulum.spring_pendulum(1.0, 1.0, 1e4 * 9.81, 9.81)),
            ("dzhanibekov", "free rigid body, I = (1, 2, 3)",
             lambda: rigidbody.free_body(rigidbody.Inertia(1.0, 2.0, 3.0)))]


def write(out: str) -> int:
    """Write every scene's derivation into ``out``: the child's work.  Exit status 0, or 3 with the reason on stderr
    where sympy (the ``derive`` extra) is missing."""
    from ...validation import InputError
    try:
        from ...inspect import derivation
        for stem, title, build in _scenes():
            files.write_text(os.path.join(out, f"derivation_{stem}.md"), derivation.markdown(build(), title))
    except InputError as exc:
        print(exc, file=sys.stderr)
        return 3
    return 0


def run(ctx: Context):
    """The built-in mechanics scenes' derivations, generated from the expressions the solver uses
    (:mod:`castrajectory.inspect.derivation`; the ``derive`` extra), one Markdown file each, linked here."""
    out = ctx.out
    lines = ["## Derivations, generated", "",
             "Each written by `castrajectory.inspect.derivation` from the CasADi expressions the solver uses "
             "(coordinates, K, U, L, M(q), the Euler–Lagrange equations with the constraints' multipliers, the "
             "discrete equations, the conserved quantities); the same as `castrajectory derive FILE.py`.", ""]
    code = f"import sys; from {__name__} import write; sys.exit(write(sys.argv[1]))"
    for _ in range(TRIES):
        try:
            got = subprocess.run([sys.executable, "-c", code, out], capture_output=True, text=True, timeout=LIMIT_S)
        except subprocess.TimeoutExpired:
            continue
        if got.returncode == 0:
            lines += [f"- [{title}](derivation_{stem}.md)" for stem, title, _ in _scenes()]
            return True, lines + [""]
        if got.returncode == 3:     # sympy missing: say so, the rest of the report stands
            return True, lines + [f"*Not generated: {got.stderr.strip()}.*", ""]
        raise RuntimeError(f"the derivations failed: {got.stderr.strip()[-2000:]}")
    return True, lines + [f"*Not generated: {TRIES} tries took over {LIMIT_S:g} s each.*", ""]
