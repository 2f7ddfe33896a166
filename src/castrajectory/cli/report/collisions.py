"""The report's collisions section (Exercise 2.2): the registry's collision scenes."""
from __future__ import annotations

from ..registry import entries
from .common import Context, script_scenes

#: the report's name of this section (its scenes print their own progress lines)
TITLE = 'collisions'
TIMED = False


def run(ctx: Context):
    return script_scenes(ctx, '## Collisions (Exercise 2.2)',
                         'Closed-form impulse of a corner impact (no Ipopt solve).',
                         entries('collisions'))
