"""The report's contact-implicit optimal-control section: the registry's scenes (each against its oracle, each
answer certified by the contact march of its controls) and, in the default and full sizes, the battery's summary.

The battery (``scripts/contact_ocp_battery.py``) is judged by its certified share alone.  Its wall times are
printed with its time goal, a benchmark of the machine at its load, which never decides the report's exit code
(issue 41: a loaded 2-core machine took 102 s on one hopper, over the goal of 60 s, and the report exited 1)."""
from __future__ import annotations

import contextlib
import importlib.util
import io
from pathlib import Path

from ..registry import entries
from .common import Context, script_scenes

TITLE = 'contact-implicit optimal control'
TIMED = False

#: the battery's run per report size: ``battery()``'s keywords (count, seed, families by name); none in the quick
#: report, and the hopper's random goals in the full one only (3 to 68 s each where the others take at most 8: with
#: them the default report's 12 problems took 142 s of its 444, loaded; the section's own hopper scene stays)
BATTERY = {"quick": None, "default": {"count": 6, "families": ["bounce", "push", "block"]}, "full": {"count": 30}}
#: the battery's script, beside the package in a source checkout (absent from an installed wheel: then no battery)
SCRIPT = Path(__file__).resolve().parents[4] / "scripts" / "contact_ocp_battery.py"


def run(ctx: Context):
    ok, lines = script_scenes(
        ctx, '## Contact-implicit optimal control (DMOC through impacts and friction)',
        "The whole MPCC in one program: the contact transcription's rows with the controls in the forces, gaps ⟂ "
        "forces and impulses, Newton's law at the bounces, Coulomb's maximal dissipation, as exact penalties raised "
        "until complementarity holds (docs/derivations.md, \"Contact-implicit DMOC\").  Every answer reported ok is "
        "certified: its controls, marched by the contact march from its initial state, reproduce it (the "
        "certificate, relative).  Each summary gives the answer against its closed form.",
        entries(TITLE), plot_name='plot')
    good, more = battery(ctx)
    return ok and good, lines + more + [""]


def _script():
    """The battery script as a module (loaded by path: ``scripts/`` is no package)."""
    spec = importlib.util.spec_from_file_location("contact_ocp_battery", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def battery(ctx: Context):
    """The battery's subsection at ``ctx.size``: ``(ok, lines)``, ok when at least the script's GOAL_SOLVED share
    of its problems is certified.  The times and the time goal are printed, not judged."""
    run_args = BATTERY.get(ctx.size)
    if not run_args or not SCRIPT.exists():
        return True, []
    mod = _script()
    kwargs = dict(run_args)
    if "families" in kwargs:
        byname = {f.__name__: f for f in mod.FAMILIES}
        kwargs["families"] = [byname[name] for name in kwargs["families"]]
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        measured = mod.battery(**kwargs)
    text = buf.getvalue().rstrip().splitlines()
    lines = [f"### Battery ({measured['count']} seeded random problems, scripts/contact_ocp_battery.py)", "",
             "Judged by the share certified; the wall times and the time goal describe this machine at its load and "
             "do not decide the report's verdict.", "", "```", *text, "```", ""]
    return bool(measured["solved_goal_met"]), lines
