"""The report's contact-implicit optimal-control section: the registry's scenes (each against its oracle, each
answer certified by the contact march of its controls) and, in the default and full sizes, the battery's summary."""
from __future__ import annotations

import contextlib
import io
import runpy
import sys
from pathlib import Path

from ..registry import entries
from .common import Context, script_scenes

TITLE = 'contact-implicit optimal control'
TIMED = False

#: the battery's problems per report size (none in the quick report)
BATTERY = {"quick": 0, "default": 12, "full": 30}


def run(ctx: Context):
    ok, lines = script_scenes(
        ctx, '## Contact-implicit optimal control (DMOC through impacts and friction)',
        "The whole MPCC in one program: the contact transcription's rows with the controls in the forces, gaps ⟂ "
        "forces and impulses, Newton's law at the bounces, Coulomb's maximal dissipation, as exact penalties raised "
        "until complementarity holds (docs/derivations.md, \"Contact-implicit DMOC\").  Every answer reported ok is "
        "certified: its controls, marched by the contact march from its initial state, reproduce it (the "
        "certificate, relative).  Each summary gives the answer against its closed form.",
        entries(TITLE), plot_name='plot')
    count = BATTERY.get(ctx.size, 0)
    if count:
        script = Path(__file__).resolve().parents[4] / "scripts" / "contact_ocp_battery.py"
        if script.exists():
            buf = io.StringIO()
            argv = sys.argv
            try:
                sys.argv = [str(script), "--count", str(count)]
                with contextlib.redirect_stdout(buf):
                    runpy.run_path(str(script), run_name="__main__")
            except SystemExit:
                pass
            finally:
                sys.argv = argv
            text = buf.getvalue().rstrip().splitlines()
            lines += [f"### Battery ({count} seeded random problems, scripts/contact_ocp_battery.py)", "", "```"] \
                + text + ["```", ""]
            ok &= any(line.startswith("goal: PASS") for line in text)
    return ok, lines + [""]
