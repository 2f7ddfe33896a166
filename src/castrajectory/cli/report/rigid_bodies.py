"""The report's rigid-body section: the registry's rigid-body scenes."""
from __future__ import annotations

from ..registry import entries
from .common import Context, script_scenes

#: the report's name of this section (its scenes print their own progress lines)
TITLE = 'rigid bodies'
TIMED = False


def run(ctx: Context):
    return script_scenes(ctx, '## Rigid bodies in 3-D (the Dzhanibekov flip and the heavy top)',
                         "Orientation as a unit quaternion with its norm as a holonomic constraint; one whole-trajectory stationary-action problem per scene. The Dzhanibekov plot shows the body rates with the located flips, the top's its tilt and precession.",
                         entries('rigid bodies'), plot_name='plot')
