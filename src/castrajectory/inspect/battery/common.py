"""The contact battery's shared pieces: gravity, the frictionless tolerances and grids, the rectangle's
clearance, and the rule that judges a refinement twin against its run."""
from __future__ import annotations

import math

G = 9.81
NS = (600, 1000, 2000, 4000)
GAP_TOL, COMP_TOL, LAW_TOL, ENERGY_TOL = 1e-8, 1e-8, 1e-6, 1e-6


def _rect_clearance(w, h, th):
    """Depth of the lowest corner below the centroid at angle th."""
    ds = [(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2)]
    return max(-(dx * math.sin(th) + dy * math.cos(th)) for dx, dy in ds)


def _check_twins(rows, floors: dict, slack: float) -> None:
    """Each twin row (2N) against its N row, on the errors ``floors`` names (each where both rows have a number):
    one is worse when it exceeds its N run's by more than ``slack`` of it and exceeds its floor.  ``twin_ok`` when
    both are solved and none is worse; a solved twin that is worse is not solved (``failed`` says which)."""
    by_id = {r["id"]: r for r in rows}
    for r in rows:
        coarse = by_id.get(r.get("twin_of"))
        if coarse is None:
            continue
        worse = []
        for key, floor in floors.items():
            a, b = coarse.get(key, math.nan), r.get(key, math.nan)
            if isinstance(a, float) and isinstance(b, float) and not (math.isnan(a) or math.isnan(b)) \
                    and b > max(a * (1 + slack), floor):
                worse.append(key)
        both = bool(coarse.get("solved") and r.get("solved"))
        r["twin_ok"] = both and not worse
        if worse and both:
            r["solved"] = False
            r["failed"] = "twin worse than its N run (" + ", ".join(worse) + ")"
