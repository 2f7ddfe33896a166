"""The report's table of what each scene carries, read from each scene's built NLP."""
from __future__ import annotations

from typing import List


def table(entries) -> List[str]:
    """The table of what each scene's NLP carries, read from the ``program`` its answer reports (the built
    NLP's own description: :meth:`castrajectory.discretise.program.Program.anatomy`)."""
    lines = ["## What each scene carries", "",
             "Read from each scene's built NLP (`program` in its JSON): the system's terms, and the program's "
             "variables, rows and complementarity pairs, in total and per step (node), and its element "
             "families (elements × SX instructions of the element function). A scene holds only the terms it "
             "lists: no complementarity without contact, no gravity when g = 0.", "",
             "| scene | terms | steps | variables (per step) | equality rows (per step) | inequality rows (per step) "
             "| complementarity pairs (per step) | element families |", "|---|---|---|---|---|---|---|---|"]
    for stem, prog in entries:
        if not prog:
            lines.append(f"| {stem} | closed form or time stepping: no NLP | - | - | - | - | - | - |")
            continue
        n = max(int(prog.get("steps", 1)), 1)
        per = (lambda k: f"{prog[k]} ({prog[k] / n:.3g})")  # noqa: E731
        fams = ", ".join(f"{f['name']} {f['elements']}×{f['instructions']}" for f in prog["families"])
        lines.append(f"| {stem} | {', '.join(prog['terms'])} | {n} | {per('variables')} | {per('equality_rows')} | "
                     f"{per('inequality_rows')} | {per('complementarity_pairs')} | {fams} |")
    return lines + [""]
