"""What every section of the report shares: the run's context and the runs of problem scripts."""
from __future__ import annotations

import importlib
import json
import os
import time
from dataclasses import dataclass, field
from typing import Callable, List

from ...inspect import files
from ..scene import SCENES, jsonable


@dataclass
class Context:
    """One report run: its folder, size (quick, default, full), progress printer and the table of what
    each scene carries (``carried``: (stem, program) of every scene run, filled by the sections)."""

    out: str
    size: str
    progress: Callable[[str, str, float], None]
    carried: List[tuple] = field(default_factory=list)


def run_case(scene: str, argv):
    """Run a scene's problem script in process at ``argv``: ``(outcome, wall time)``."""
    mod = importlib.import_module(SCENES[scene])
    t0 = time.perf_counter()
    outcome = mod.run(mod.parser().parse_args(argv))
    return outcome, time.perf_counter() - t0


def script_scenes(ctx: Context, heading: str, intro: str, scenes, plot_name: str = "energy"):
    """A section of problem-script runs (``scenes``: the registry's ``(stem, scene, argv, title, animate)``):
    each run's summary, JSON, plot and animation."""
    out = ctx.out
    lines = [heading, "", intro, ""]
    ok = True
    for stem, scene, argv, title, animate in scenes:
        outcome, wall = run_case(scene, argv)
        ok &= outcome.success
        ctx.carried.append((stem, outcome.data.get("program")))
        ctx.progress(stem, outcome.status, wall)
        files.write_text(os.path.join(out, f"{stem}.json"), json.dumps(jsonable(outcome.data), allow_nan=False))
        lines += [f"### {title}", "", f"`python problems/{scene}.py {' '.join(argv)}`".replace(" `", "`"), "",
                  "```", *outcome.summary, "```", ""]
        if outcome.success and "plot" in outcome.writers:
            files.write_atomically(os.path.join(out, f"{stem}_{plot_name}.png"), outcome.writers["plot"])
            lines += [f"![{title}: {plot_name}]({stem}_{plot_name}.png)", ""]
            if animate:
                files.write_atomically(os.path.join(out, f"{stem}.gif"), outcome.writers["animate"])
                lines += [f"![{title}: animation]({stem}.gif)", ""]
    return ok, lines
