"""The report's "drops under gravity" section (issue #26): the shape-against-Bond study (height and contact
radius, 2-D and 3-D, NLP against the closed form / the Young–Laplace shooting) and the pendant folds (the 2-D
A* and the 3-D V_max found by the NLP's continuation against the closed form and the shooting).  Its
stability rows (a puddle, θ = 175° under gravity, a pendant drop just below and just above its fold) are
the droplet scene's cases in the registry, shown in the stability table."""
from __future__ import annotations

import os
import time

import numpy as np

from ...inspect import bond, files
from ...solve import droplet
from .common import Context

TITLE = "drops under gravity"
TIMED = True

#: Per size: the Bond numbers of the study (oracle), those also solved as NLPs, and the NLP's N of the folds.
#: (3-D oracles above Bo ~ 300 cost seconds each (the shooting at Bo = 1e3: 14 s); the full study is
#: scripts/droplet_bond_study.py.)
STUDY = {"quick": (np.logspace(-3, 2, 6), (0.1, 10.0), 40, None),
         "default": (np.logspace(-3, 2.5, 12), (1e-3, 1e-2, 0.1, 1.0, 10.0), 50, 1e-2),
         "full": (np.logspace(-3, 3, 13), (1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0, 1e3), 100, 1e-4)}


#: The spectral profile's degree for the folds (docs/derivations.md, Droplet §12).
SPECTRAL_FOLD_DEGREE = 16


def _fold(axisymmetric: bool, n: int, formulation: str = "curve") -> dict:
    """The pendant family followed past its fold at θ = 90° (l_c = 1): the NLP's last stable measure."""
    d = droplet.Droplet(1.0, 1.0, 1.0, 6.0 if axisymmetric else 3.0, None, 1.0, True, axisymmetric)
    t0 = time.perf_counter()
    sol = droplet.solve(d, n, formulation)
    fold = (sol.stability or {}).get("fold") or {}
    return {"status": sol.status, "n": n, "formulation": formulation, "found": fold.get("area"),
            "exact": fold.get("analytic_area"),
            "error": (sol.errors or {}).get("fold_area"), "time_s": time.perf_counter() - t0,
            "iterations": sol.iterations}


def run(ctx: Context):
    out, size = ctx.out, ctx.size
    bonds, nlp_bonds, n_fold, peak_rtol = STUDY[size]
    rows = bond.sweep(bonds, nlp_bonds=nlp_bonds)
    peak = None if peak_rtol is None else bond.overshoot(rtol=peak_rtol)
    found = bond.findings(rows, 90.0, peak)
    bond.write_csv(rows, os.path.join(out, "droplet_bond_study.csv"))
    files.write_atomically(os.path.join(out, "droplet_bond_study.png"), lambda p: bond.plot(rows, p, 90.0, peak))
    ok = all(r["status"] in ("ok", "-") for r in rows)
    lines = ["## Drops under gravity (issue #26)", "",
             "Sessile drops at θ = 90° in units of the capillary length l_c = √(γ/ρg): the Bond number is A/l_c² "
             "(2-D) or V^(2/3)/l_c² (a drop of revolution).  Oracle: the closed form in elliptic integrals (2-D), "
             "the Young–Laplace shooting (3-D); NLP at the Bond numbers shown with N.  Data in "
             "`droplet_bond_study.csv`; the whole study (Bo = 1e-3 … 1e3): `python scripts/droplet_bond_study.py`.",
             "", *bond.markdown(rows), "", *("- " + ln for ln in found["lines"]), "",
             "![height and contact radius against the Bond number](droplet_bond_study.png)", ""]
    # ---- the folds
    folds = [("2-D pendant drop: largest area A* (closed form)", _fold(False, n_fold)),
             ("3-D pendant drop of revolution: largest volume V_max (shooting)", _fold(True, n_fold))]
    if size != "quick":  # (5 s: the 3-D family checks its reduced Hessian at each of its ~40 steps)
        folds += [("2-D, spectral profile", _fold(False, SPECTRAL_FOLD_DEGREE, "spectral")),
                  ("3-D, spectral profile", _fold(True, SPECTRAL_FOLD_DEGREE, "spectral"))]
    lines += ["### The pendant folds (θ = 90°)", "",
              "The family followed by continuation in the area (volume) with the reduced Hessian checked at each "
              "step; beyond the last stable drop the run ends with the status No_Stable_Drop (the verdict, not a "
              "failure).  The polyline's fold converges at order 2 (tests/test_droplet_gravity.py, "
              "tests/test_droplet_axisymmetric.py); the spectral profile's (its tangent angle a polynomial of the "
              "degree shown, docs/derivations.md Droplet §12) is limited by the bracket's width, 1e-7 "
              "(tests/test_droplet_spectral.py).", "",
              "| fold | N or degree | status | NLP's fold | closed form / shooting | relative error | iterations | time (s) |",
              "|---|---|---|---|---|---|---|---|"]
    for title, f in folds:
        good = f["status"] == droplet.NO_STABLE_DROP and f["found"] is not None
        ok &= good
        lines.append(f"| {title} | {f['n']} | {f['status']} | {f['found'] if f['found'] is None else format(f['found'], '.7f')} | "
                     f"{f['exact'] if f['exact'] is None else format(f['exact'], '.7f')} | "
                     f"{'-' if f['error'] is None else format(f['error'], '.2e')} | {f['iterations']} | "
                     f"{f['time_s']:.2f} |")
    lines += ["", "Stability rows of these drops (a puddle at Bo = 1e4, θ = 175° under gravity, a pendant drop just "
              "below and just above its fold) are in the stability table, family droplet.", ""]
    return ok, lines
