"""The scene registry: every scene registered once, with all it takes part in.

A :class:`Scene` names its problem script (``problems/<name>.py``, installed as
``castrajectory.problems.<name>``), the report section that shows it and the runs it shows there
(:class:`Entry`: a file stem, the script's arguments, a title, and whether to animate), and its
stability cases (:class:`~castrajectory.cli.cases.Case`, each a command and its oracle).  The
console command (``castrajectory list`` / ``run``), the report's sections
(:mod:`castrajectory.cli.report`) and the stability table (:mod:`castrajectory.cli.stability`) all read
this one list: adding a scene is one entry here and one file in ``problems/``, and touches no other
scene.

The stability tolerances are the measured errors with a margin (the measured values in the comments).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, List, Tuple

from .cases import (Case, chaotic_reference, contact_check, droplet_check, energy_bounded, flip_interval,
                        no_flip, puddle_check, rigid_pendulum)


@dataclass(frozen=True)
class Entry:
    """One run of a scene in the report: its files' stem, the script's arguments, a title, animate?"""

    stem: str
    argv: Tuple[str, ...]
    title: str
    animate: bool = False


@dataclass(frozen=True)
class Scene:
    """A scene: its name (the problem script's), its report section, its report runs and its stability cases."""

    name: str
    section: str = ""
    report: Tuple[Entry, ...] = ()
    stability: Tuple[Case, ...] = ()

    @property
    def module(self) -> str:
        return f"castrajectory.problems.{self.name}"


#: γ_sl giving Young's angles 2°, 90°, 175° and 178° (γ_gl = γ_sg = 1)
GSL = {2: 1.0 - math.cos(math.radians(2.0)), 90: 1.0, 175: 1.0 - math.cos(math.radians(175.0)),
       178: 1.0 - math.cos(math.radians(178.0))}
_ANGLE = "contact angle against Young's (rad)"
_SHAPE = "shape: max distance to the analytic circle / R"

SCENES: List[Scene] = [
    Scene("droplet", "droplet", stability=(
        # Young's angle at the extremes, and a large N (measured errors in the comments)
        Case("droplet", "θ = 2° (nearly wetting), curve", "droplet", ("--gamma-sl", f"{GSL[2]:.12g}", "--n", "400"),
             droplet_check("contact_angle", 1e-5, _ANGLE)),                                      # 1.1e-7
        Case("droplet", "θ = 2°, graph", "droplet", ("--gamma-sl", f"{GSL[2]:.12g}", "--n", "400", "--formulation",
                                                       "graph"), droplet_check("contact_angle", 1e-5, _ANGLE)),
        Case("droplet", "θ = 90°, curve", "droplet", ("--gamma-sl", "1", "--n", "400"),
             droplet_check("contact_angle", 1e-4, _ANGLE)),
        Case("droplet", "θ = 178° (nearly non-wetting), curve", "droplet",
             ("--gamma-sl", f"{GSL[178]:.12g}", "--n", "4000"), droplet_check("contact_angle", 1e-4, _ANGLE)),
        Case("droplet", "N = 10⁵, curve", "droplet", ("--n", "100000"), droplet_check("shape", 1e-9, _SHAPE)),
        Case("droplet", "N = 10⁵, graph", "droplet", ("--n", "100000", "--formulation", "graph"),
             droplet_check("shape", 1e-9, _SHAPE)),
        # drops under gravity (#26; the report's section "drops under gravity"), θ = 90° unless said
        Case("droplet", "a puddle under gravity, Bo = 10⁴ (l_c = 0.01)", "droplet",
             ("--gravity", "1e4", "--gamma-sl", "1", "--n", "2000"), puddle_check(90.0, 1e-3), slow=True),  # 1.1e-4
        Case("droplet", "θ = 175° under gravity (Bo = 1)", "droplet", ("--gravity", "1", "--gamma-sl",
                                                                     f"{GSL[175]:.12g}", "--n", "400"),
             droplet_check("height", 1e-4, "height against the closed form (relative)")),          # 7.2e-6
        Case("droplet", "pendant drop just below its fold (A = 2.7, A* = 2.7151505)", "droplet",
             ("--gravity", "1", "--gamma-sl", "1", "--pendant", "--area", "2.7", "--n", "50"),
             droplet_check("height", 1e-2, "height against the closed form (relative; N = 50)")),   # 3.4e-3
        Case("droplet", "pendant drop just above its fold (A = 2.73): no stable drop", "droplet",
             ("--gravity", "1", "--gamma-sl", "1", "--pendant", "--area", "2.73", "--n", "50"),
             droplet_check("fold_area", 3e-3, "the last stable area against the closed form's fold A* "
                                             "(relative; N = 50, order 2)"), expect="no_stable_drop"),   # 1.2e-3
    )),
    Scene("droplet_angle", "droplet"),
    Scene("double_pendulum", "mechanics", report=(
        Entry("double_pendulum", (), "double pendulum, θ = (2, 1) at rest, T = 10 s (chaotic)", True),
        Entry("double_pendulum_galerkin4", ("--T", "5", "--n", "2000", "--scheme", "galerkin4"),
              "double pendulum, galerkin4, T = 5 s"),
        Entry("double_pendulum_g0", ("--g", "0", "--omega1", "1", "--T", "5", "--n", "1000"),
              "double pendulum without gravity (g = 0: the system has no gravity term)"),
    ), stability=(
        Case("pendulum", "chaotic double pendulum, T = 10 s, rtol 1e-6", "double_pendulum",
             ("--scheme", "galerkin4", "--rtol", "1e-6"), chaotic_reference(1e-6)),
    )),
    Scene("n_link_pendulum", "mechanics", report=(Entry("n_link_pendulum", (), "4-link pendulum", True),), stability=(
        Case("pendulum", "1000 periods (amplitude 0.1 rad, 20 steps per period)", "n_link_pendulum",
             ("--links", "1", "--theta", "0.1", "--T", f"{1000 * 2 * math.pi / math.sqrt(9.81):.6f}", "--n", "20000"),
             energy_bounded(1e-2)),
    )),
    Scene("stiff_spring_pendulum", "mechanics", report=(
        Entry("stiff_spring_1e4", ("--ratio", "1e4"), "stiff spring pendulum, k l/(m g) = 1e4", True),
        Entry("stiff_spring_1e6", ("--ratio", "1e6"), "stiff spring pendulum, k l/(m g) = 1e6 (h ω ≈ 16)"),
    ), stability=(
        # far beyond the step's resolution of the radial motion
        Case("stiff spring", "k l/(m g) = 10⁶ (h ω ≈ 16)", "stiff_spring_pendulum", ("--ratio", "1e6"),
             rigid_pendulum(1e-2)),
        Case("stiff spring", "k l/(m g) = 10⁸ (h ω ≈ 160)", "stiff_spring_pendulum", ("--ratio", "1e8"),
             rigid_pendulum(1e-2)),
    )),
    Scene("thrown_ball", "mechanics", report=(
        Entry("thrown_ball", (), "thrown ball (two-point boundary, least action)"),)),
    Scene("damped_oscillator", "mechanics", report=(
        Entry("damped_oscillator", ("--scheme", "galerkin6"),
              "damped, driven oscillator (Lagrange–d'Alembert), galerkin6, against the closed form"),)),
    Scene("driven_pendulum", "mechanics", report=(
        Entry("driven_pendulum", (), "damped, driven pendulum, chaotic regime, T = 20 s"),)),
    Scene("kapitza_pendulum", "mechanics", report=(
        Entry("kapitza_pendulum", (), "Kapitza pendulum: a²ω²/2gl = 5.1, started 0.2 rad off upright", True),)),
    Scene("collision_impulse", "collisions", report=(
        Entry("collision_impulse", (), "corner impact of a 2 × 1 rectangle, e = 1"),
        Entry("collision_impulse_flat", ("--angle", "0", "--vx", "0", "--vy", "-1", "--restitution", "0"),
              "flat fall onto a corner, e = 0 (oracle μ = 5/17)"),
    )),
    Scene("bouncing_ball", "contact", report=(
        Entry("bouncing_ball", (), "bouncing ball, e = 1, N = 3000 (3 bounces)", True),
        Entry("bouncing_ball_e07", ("--restitution", "0.7", "--T", "5", "--n", "2000"),
              "bouncing ball, e = 0.7, T = 5 s (settles)"),
    ), stability=(
        # the scenes' own oracles (closed-form bounce times, apexes, m g h per node)
        Case("contact", "high-speed impact (443 m/s, 100× the default)", "bouncing_ball",
             ("--velocity", "-442.9", "--T", "0.5", "--n", "1000"),
             contact_check((("impact_time_error", 1e-12), ("apex_error", 1e-9)), "bounce times (s), apexes (m)")),
        Case("contact", "resting contact (ball at rest on the ground)", "bouncing_ball",
             ("--height", "0", "--T", "1", "--n", "200"),
             contact_check((("resting_impulse_error", 1e-12),), "impulse per node against m g h (relative)")),
        Case("contact", "Zeno-like bouncing, e = 0.3", "bouncing_ball", ("--restitution", "0.3", "--T", "3", "--n", "1500"),
             contact_check((("impact_time_error", 1e-12), ("apex_error", 1e-12), ("resting_impulse_error", 1e-12)),
                           "bounce times (s), apexes (m), then m g h per node")),
    )),
    Scene("sliding_block", "contact", report=(
        Entry("sliding_block", ("--incline", "0.3", "--v0", "2", "--n", "200"),
              "sliding block launched up a 0.3 rad incline, μ = 0.5: it stops and sticks (Coulomb friction)", True),
    ), stability=(
        # a held contact over a long horizon on coarse steps: the block stays at rest to rounding (measured 0 m)
        Case("contact", "long resting contact (a block at rest for 10⁴ s on 10³ steps of 10 s)", "sliding_block",
             ("--v0", "0", "--T", "10000", "--n", "1000"),
             contact_check((("error_vs_exact", 1e-12),), "position against rest (m)")),
    )),
    Scene("sliding_ladder", "contact", report=(
        Entry("sliding_ladder", (), "a ladder sliding down a frictionless wall: both contacts held at the stages, its "
              "lift-off from the wall timed inside its step (galerkin4)", True),
    ), stability=(
        # the wall's force reaches zero with the gap growing as (t − t*)³ after it (measured galerkin4, N = 50:
        # lift-off 3.7e-11 s, θ before it 3.3e-10 rad)
        Case("contact", "grazing release: the ladder leaves the wall, its gap growing as (t − t*)³", "sliding_ladder",
             ("--n", "50"), contact_check((("lift_off_error", 4e-9), ("theta_error", 3e-8)),
                                         "lift-off time (s), θ before it (rad)")),
    )),
    Scene("disk_in_bowl", "contact", report=(
        Entry("disk_in_bowl", (), "a disk rolling in a bowl (μ = 1): the held contact's force and friction at the "
              "stages, fourth order with galerkin4", True),
        Entry("disk_in_bowl_slip", ("--mu", "0.05", "--T", "3", "--n", "300"),
              "the same disk with μ = 0.05: it slides, its slip reverses twice, stops and starts again, each event "
              "timed inside its step"),
    ), stability=(
        # stick–slip at a small μ (measured galerkin4, N = 300: configuration 5.1e-10 m, events 1.8e-10 s)
        Case("contact", "stick–slip at μ = 0.05: two reversals, a stop and a start in 3 s", "disk_in_bowl",
             ("--mu", "0.05", "--T", "3", "--n", "300"),
             contact_check((("error_vs_reference", 5e-8), ("slip_event_error", 2e-8)),
                           "configuration (m), slip events (s)")),
    )),
    Scene("rolling_ball", "contact", report=(
        Entry("rolling_ball", ("--n", "200"), "a sphere launched sliding at 2 m/s without spin, μ = 0.3: it rolls "
              "from 2v₀/(7μg) on at 5v₀/7", True),
    )),
    Scene("pushed_box", "contact", report=(
        Entry("pushed_box", ("--mu", "0.8", "--force", "5.2"),
              "a box pushed at half its height, μ = 0.8: it tips about its front corner (statics: above 4.905 N)"),
    )),
    Scene("rimless_wheel", "contact"),
    Scene("newtons_cradle", "contact", report=(
        Entry("newtons_cradle", ("--balls", "3", "--n", "200"),
              "Newton's cradle, 3 touching balls, the sequential law (the last leaves, the others stop)", True),
    )),
    Scene("rectangle_drop", "contact", report=(
        Entry("rectangle_drop", (), "rectangle drop, θ₀ = 0.3, e = 1", True),
    ), stability=(
        # the corner impact law
        Case("contact", "grazing corner (g = 0, spinning, 1e-4 m overlap of the sweep)", "rectangle_drop",
             ("--g", "0", "--y", "1.1179339887", "--angle", "0", "--vx", "0", "--vy", "0", "--omega", "2",
              "--T", "1.5", "--n", "1000"), contact_check((("impact_law_error", 1e-9),), "impact law (relative)")),
        Case("contact", "flat rectangle landing (θ₀ = 0: two corners at once)", "rectangle_drop",
             ("--angle", "0", "--vx", "0", "--omega", "0", "--y", "1.5", "--T", "1.5", "--n", "1000"),
             contact_check((("impact_law_error", 1e-9),), "simultaneous impact law (relative)")),
        Case("contact", "nearly flat landing (θ₀ = 0.01: corners 2.5 ms apart, h = 1.5 ms)", "rectangle_drop",
             ("--angle", "0.01", "--vx", "0", "--omega", "0", "--y", "1.5", "--T", "1.5", "--n", "1000"),
             contact_check((("impact_law_error", 1e-9),), "sequential corner impacts, impact law (relative)")),
        Case("contact", "flatter landing (θ₀ = 1e-3: three impacts within 0.74 ms, h = 1.5 ms)", "rectangle_drop",
             ("--angle", "0.001", "--vx", "0", "--omega", "0", "--y", "1.5", "--T", "1.5", "--n", "1000"),
             contact_check((("impact_law_error", 1e-9),), "impact law in a cascade within one step (relative)")),
        Case("contact", "rocking block, e = 0.5 (rocking accumulation on the edge)", "rectangle_drop",
             ("--restitution", "0.5"),
             contact_check((("impact_law_error", 1e-3),), "impact law (relative; 2e-4 measured: the "
                                                          "accumulation's last bounces, nearly caught)")),
        Case("contact", "rocking block, e = 0.3", "rectangle_drop", ("--restitution", "0.3"),
             contact_check((("impact_law_error", 1e-9),), "impact law (relative)")),
    )),
    Scene("bowl", "contact", report=(Entry("bowl", (), "rectangle in a bowl y = x²/(2R), e = 1", True),)),
    Scene("bowl3d", "contact", report=(
        Entry("bowl3d", (), "box on SO(3) in the bowl z = (x² + y²)/(2R), e = 1, eight corners"),)),
    Scene("dzhanibekov", "rigid bodies", report=(
        Entry("dzhanibekov", (), "Dzhanibekov flip: I = (1, 2, 3), ω₀ = (1e-3, 1, 1e-3), T = 100 s", True),
    ), stability=(
        Case("rigid body", "nearly symmetric body, I = (1, 2.999, 3): flips every 391 s", "dzhanibekov",
             ("--inertia", "1", "2.999", "3", "--T", "1000", "--n", "20000"), flip_interval(3e-3)),   # 6.3e-4
        Case("rigid body", "fast spin |ω| = 100 rad/s on the default grid (h|ω| = 2.5 rad per step)", "dzhanibekov",
             ("--omega", "1e-3", "100", "1e-3"), None, expect="unresolved"),
        Case("rigid body", "fast spin |ω| = 100 rad/s over T = 5 s (h|ω| = 0.125)", "dzhanibekov",
             ("--omega", "1e-3", "100", "1e-3", "--T", "5"), flip_interval(1e-2)),                  # 4.3e-3
        Case("rigid body", "20 flips (T = 560 s, N = 11200)", "dzhanibekov", ("--T", "560", "--n", "11200"),
             flip_interval(3e-3)),                                                                   # 7e-4
        Case("rigid body", "spin exactly on the intermediate axis, ω₀ = (0, 1, 0)", "dzhanibekov",
             ("--omega", "0", "1", "0"), no_flip(1e-12)),
    )),
    Scene("heavy_top", "rigid bodies", report=(
        Entry("heavy_top", ("--reference",), "heavy top: spin 100 rad/s, tilt 0.3 rad, T = 2 s, "
              "against Euler–Poisson (CVODES)", True),)),
    # optimal control on the discrete action (#24)
    Scene("block_move", "optimal control", report=(
        Entry("block_move", (), "block move, midpoint, N = 50: the exact discrete optimum J* N²/(N²−1)"),
        Entry("block_move_galerkin4", ("--scheme", "galerkin4", "--n", "10"),
              "block move, galerkin4 with controls at its quadrature nodes, N = 10: J* itself"))),
    Scene("min_time", "optimal control", report=(
        Entry("min_time", (), "minimum-time move, |u| <= 1: bang-bang, T* = 2"),)),
    Scene("damped_transfer", "optimal control", report=(
        Entry("damped_transfer", ("--scheme", "galerkin6", "--n", "20"),
              "damped transfer, galerkin6, N = 20, against the controllability Gramian"),)),
    Scene("satellite_slew", "optimal control", report=(
        Entry("satellite_slew", (), "satellite slew on SO(3), spherical inertia: J* = 12 j² Θ²/T³"),)),
    Scene("cartpole_swingup", "optimal control", report=(
        Entry("cartpole_swingup", ("--scheme", "galerkin8", "--n", "50"),
              "cart-pole swing-up, galerkin8, N = 50, against Kelly's J*", True),)),
    Scene("pendulum_swingup", "optimal control", report=(
        Entry("pendulum_swingup", (), "pendulum swing-up, |u| <= 3, midpoint, N = 200", True),)),
    # contact-implicit optimal control (#27)
    Scene("block_push", "contact-implicit optimal control", report=(
        Entry("block_push", (), "block push with friction, slides the whole horizon: the exact discrete optimum"),
        Entry("block_push_sticks", ("--T", "2", "--n", "80"),
              "block push, T > τ*: slides τ* = √(6d/(μg)) and sticks, against J* = (4/3)(μmg)²τ*"))),
    Scene("bounce_to_target", "contact-implicit optimal control", report=(
        Entry("bounce_to_target", (), "bounce to a target: launch speed and horizon unknown, k = 2, e = 0.9 "
              "(rockit's case), against the closed form"),)),
    Scene("hopper", "contact-implicit optimal control", report=(
        Entry("hopper", (), "nosnoc's hopper: a hop to x = 0.7 tracking the staged reference, certified (nosnoc's own "
              "answer costs 11.38: scripts/bench_contact_ocp.py --hopper)", animate=True),)),
    Scene("push_to_target", "contact-implicit optimal control", report=(
        Entry("push_to_target", (), "push to a target: falls, lands at √(2 y0/g), slides and sticks; e = 0, μ = 0.6"),)),
]

#: The stability table's order of families (a family's cases in the order of its scenes)
FAMILIES = ("droplet", "stiff spring", "pendulum", "contact", "rigid body")


def scene_modules() -> Dict[str, str]:
    """Scene name -> module of its problem script, in the registry's order."""
    return {s.name: s.module for s in SCENES}


def module(name: str) -> str:
    return scene_modules()[name]


def entries(section: str) -> List[tuple]:
    """The report runs of ``section``'s scenes: ``(stem, scene, argv, title, animate)``."""
    return [(e.stem, s.name, list(e.argv), e.title, e.animate) for s in SCENES if s.section == section
            for e in s.report]


def cases() -> List[Case]:
    """Every scene's stability cases, grouped by family in :data:`FAMILIES` order."""
    every = [c for s in SCENES for c in s.stability]
    order = {f: i for i, f in enumerate(FAMILIES)}
    return sorted(every, key=lambda c: order.get(c.family, len(order)))
