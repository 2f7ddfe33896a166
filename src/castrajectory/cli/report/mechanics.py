"""The report's mechanics section (Exercise 2.3): the registry's mechanics scenes."""
from __future__ import annotations

from ..registry import entries
from .common import Context, script_scenes

#: the report's name of this section (its scenes print their own progress lines)
TITLE = 'mechanics'
TIMED = False


def run(ctx: Context):
    return script_scenes(ctx, '## Mechanics: least action over the whole trajectory (Exercise 2.3)',
                         'Each scene is solved by its problem script at the arguments shown; the energy plot shows |E − E(0)| over the run (a forced or time-dependent scene: the balance |E − E(0) − W|).',
                         entries('mechanics'))
