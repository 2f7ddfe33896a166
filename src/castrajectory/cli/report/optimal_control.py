"""The report's optimal-control section: the registry's DMOC scenes, each against its oracle."""
from __future__ import annotations

import numpy as np

from ...models.control import Control
from ...models.mechanics import Damping, Force, LagrangianSystem, MassMatrix, Potential
from ...solve.optimal_control import OptimalControl
from ..registry import entries
from .common import Context, script_scenes

#: the damped transfer's optimum (c = 0.5, k = 1, T = 2, d = 1: the controllability Gramian)
DAMPED_J = 1.674735875385

#: the report's name of this section (its scenes print their own progress lines)
TITLE = 'optimal control'
TIMED = False


def _damped_cost(N: int, scheme: str) -> float:
    import casadi as ca
    u = Control("w", 1)
    x = ca.SX.sym("x", 1)
    system = LagrangianSystem(x, MassMatrix(1.0), [Potential(0.5 * x[0] ** 2, "spring"), Damping(0.5), Force(u)])
    ocp = OptimalControl(system, T=2.0, N=N, scheme=scheme)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[1.0], qd=[0.0])
    ocp.minimize(running=u ** 2)
    sol = ocp.solve()
    return sol.cost if sol.success else float("nan")


def orders():
    """The damped transfer's cost against the Gramian's J*, per scheme (controls at the quadrature nodes):
    errors on three grids and the fitted order (the slope of log error against log N)."""
    rows = []
    for scheme, ns in (("midpoint", (20, 40, 80)), ("galerkin4", (5, 10, 20)), ("galerkin6", (5, 10, 20))):
        errs = [abs(_damped_cost(n, scheme) - DAMPED_J) for n in ns]
        order = -np.polyfit(np.log(ns), np.log(errs), 1)[0]
        rows.append((scheme, ns, errs, float(order)))
    return rows


def run(ctx: Context):
    ok, lines = _scenes(ctx)
    lines += ["### Orders", "", "The damped transfer's cost against the controllability Gramian's J* = "
              f"{DAMPED_J}, controls at each scheme's quadrature nodes (fitted slope of log error against log N):", "",
              "| scheme | N | error of J | fitted order |", "|---|---|---|---|"]
    for scheme, ns, errs, order in orders():
        lines.append(f"| {scheme} | {', '.join(map(str, ns))} | {', '.join(f'{e:.2e}' for e in errs)} | {order:.2f} |")
        ok &= bool(np.isfinite(order))
    return ok, lines + [""]


def _scenes(ctx: Context):
    return script_scenes(ctx, '## Optimal control on the discrete action (DMOC)',
                         "The discrete Lagrange–d'Alembert equations with controls in the forces, boundary velocities "
                         "through the discrete Legendre transforms, one NLP for the whole trajectory; each answer's "
                         "controls are marched with the same equations (the certificate). Each summary gives the "
                         "cost against its closed form or published optimum; the plot shows the configuration and "
                         "the controls.", entries('optimal control'), plot_name='plot')
