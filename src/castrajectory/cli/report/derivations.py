"""The report's generated derivations of the built-in mechanics scenes."""
from __future__ import annotations

import os

from ...inspect import files
from .common import Context

TITLE = 'generated derivations'
TIMED = True


def run(ctx: Context):
    """The built-in mechanics scenes' derivations, generated from the expressions the solver uses
    (:mod:`castrajectory.inspect.derivation`; the ``derive`` extra), one Markdown file each, linked here."""
    out = ctx.out
    from ...models import pendulum, rigidbody
    from ...validation import InputError
    scenes = [("double_pendulum", "double pendulum", pendulum.double_pendulum()),
              ("n_link_pendulum", "4-link pendulum", pendulum.n_link_pendulum([1.0] * 4, [1.0] * 4, 9.81)),
              ("stiff_spring_pendulum", "spring pendulum (k l/(m g) = 1e4)",
               pendulum.spring_pendulum(1.0, 1.0, 1e4 * 9.81, 9.81)),
              ("dzhanibekov", "free rigid body, I = (1, 2, 3)", rigidbody.free_body(rigidbody.Inertia(1.0, 2.0, 3.0)))]
    lines = ["## Derivations, generated", "",
             "Each written by `castrajectory.inspect.derivation` from the CasADi expressions the solver uses "
             "(coordinates, K, U, L, M(q), the Euler–Lagrange equations with the constraints' multipliers, the "
             "discrete equations, the conserved quantities); the same as `castrajectory derive FILE.py`.", ""]
    try:
        from ...inspect import derivation
        for stem, title, system in scenes:
            files.write_text(os.path.join(out, f"derivation_{stem}.md"), derivation.markdown(system, title))
            lines.append(f"- [{title}](derivation_{stem}.md)")
    except InputError as exc:   # sympy missing: say so, the rest of the report stands
        lines.append(f"*Not generated: {exc}.*")
    return True, lines + [""]
