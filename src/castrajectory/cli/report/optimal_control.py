"""The report's optimal-control section: the registry's DMOC scenes, each against its oracle."""
from __future__ import annotations

import numpy as np

from ..registry import entries
from .common import Context, run_case, script_scenes

#: the report's name of this section (its scenes print their own progress lines)
TITLE = 'optimal control'
TIMED = False

#: the damped transfer's errors against its closed form (problems/damped_transfer.py --json), by name
ERRORS = (("J", "error_vs_exact"), ("u", "control_error"), ("(x, ẋ)", "state_error"), ("costate", "costate_error"))


def orders():
    """The damped transfer (c = 0.5, k = 1, T = 2, d = 1) against its closed form, per scheme (controls at the
    quadrature nodes): the errors of the cost, the controls, the nodal state and the costates on three grids,
    and each one's fitted order (the slope of log error against log N)."""
    rows = []
    for scheme, ns in (("midpoint", (20, 40, 80)), ("galerkin4", (5, 10, 20)), ("gauss4", (5, 10, 20)),
                       ("galerkin6", (4, 8, 16))):
        errs = {key: [] for _, key in ERRORS}
        for n in ns:
            outcome, _ = run_case("damped_transfer", ["--scheme", scheme, "--n", str(n)])
            for key in errs:
                errs[key].append(outcome.data.get(key, float("nan")) if outcome.success else float("nan"))
        fitted = {key: float(-np.polyfit(np.log(ns), np.log(e), 1)[0]) for key, e in errs.items()}
        rows.append((scheme, ns, errs, fitted))
    return rows


def run(ctx: Context):
    ok, lines = _scenes(ctx)
    lines += ["### Orders", "",
              "The damped transfer (c = 0.5, k = 1, T = 2, d = 1) against its closed form (the controllability "
              "Gramian), controls at each scheme's quadrature nodes: fitted slopes of log error against log N "
              "(the errors are the largest over the nodes, or over the control points for u).  The cost, the "
              "nodal states and the costates converge at the scheme's order; the controls at the quadrature "
              "nodes at one more than the number of nodes (midpoint 2, galerkin4 4, gauss4 3, galerkin6 5): "
              "a control value is the Hamiltonian's minimiser at its node, where the discrete adjoint is a "
              "stage value, accurate to the stage order and not to the nodes' superconvergent order.", "",
              "| scheme | N | " + " | ".join(f"error of {name}" for name, _ in ERRORS) + " | "
              + " | ".join(f"order of {name}" for name, _ in ERRORS) + " |",
              "|---" * (2 + 2 * len(ERRORS)) + "|"]
    for scheme, ns, errs, fitted in orders():
        lines.append(f"| {scheme} | {', '.join(map(str, ns))} | "
                     + " | ".join(", ".join(f"{e:.1e}" for e in errs[key]) for _, key in ERRORS) + " | "
                     + " | ".join(f"{fitted[key]:.2f}" for _, key in ERRORS) + " |")
        ok &= all(np.isfinite(v) for v in fitted.values())
    return ok, lines + [""]


def _scenes(ctx: Context):
    return script_scenes(ctx, '## Optimal control on the discrete action (DMOC)',
                         "The discrete Lagrange–d'Alembert equations with controls in the forces, boundary velocities "
                         "through the discrete Legendre transforms, one NLP for the whole trajectory; each answer's "
                         "controls are marched with the same equations (the certificate). Each summary gives the "
                         "cost against its closed form or published optimum; the plot shows the configuration and "
                         "the controls.", entries('optimal control'), plot_name='plot')
