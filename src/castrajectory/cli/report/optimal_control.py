"""The report's optimal-control section: the registry's DMOC scenes, each against its oracle."""
from __future__ import annotations

from ..registry import entries
from .common import Context, script_scenes

#: the report's name of this section (its scenes print their own progress lines)
TITLE = 'optimal control'
TIMED = False


def run(ctx: Context):
    return script_scenes(ctx, '## Optimal control on the discrete action (DMOC)',
                         "The discrete Lagrange–d'Alembert equations with controls in the forces, boundary velocities "
                         "through the discrete Legendre transforms, one NLP for the whole trajectory; each answer's "
                         "controls are marched with the same equations (the certificate). Each summary gives the "
                         "cost against its closed form or published optimum; the plot shows the configuration and "
                         "the controls.", entries('optimal control'), plot_name='plot')
