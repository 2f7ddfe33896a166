"""The report's contact-trajectory section: the registry's contact scenes."""
from __future__ import annotations

from ..registry import entries
from .common import Context, script_scenes

#: the report's name of this section (its scenes print their own progress lines)
TITLE = 'contact'
TIMED = False


def run(ctx: Context):
    return script_scenes(ctx, '## Contact trajectories (complementarity-constrained discrete action)',
                         'One whole-trajectory NLP per scene: collision sub-nodes with unknown impact times, gap ⟂ impulse by exact penalties, Newton restitution on the discrete momenta (docs/derivations.md). The plot shows heights/gaps over the impulses per node.',
                         entries('contact'), plot_name='contact')
