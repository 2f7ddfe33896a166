"""The march's vocabulary: the contact modes of a step and the friction modes of its slots, and what follows from
them alone (which contacts release at a step's impact, where a slip turns).  The compiled step is :mod:`.step`, the
search for a step's modes :mod:`.search`, the march :mod:`.march`."""
from __future__ import annotations

import numpy as np

#: contact modes (:mod:`.march`'s docstring): open, held, released at the sub-node, impact, caught, impact at the
#: node, an impulse fixed by the sequential law (F at the sub-node, T timing it), P the same at the node
O, H, R, I, C, N, F, T, P = "O", "H", "R", "I", "C", "N", "F", "T", "P"
#: a plastic arrival with friction caught at its sub-node (closed after it) whose impulse is Stronge's, fixed as the
#: first part's closing impulse μ⁻ (its normal and its ratio; the second part's μ holds the contact closed after)
K = "K"
#: a held contact with planar friction whose slip stops or turns at the sub-node, which it times (its slip velocity
#: there vanishes after its share of the first part's force; it slides through the first part, and sticks or
#: slides the other way through the second)
W = "W"
#: a held contact released inside the step, at its sub-node, which it times: its normal force of the continuous motion
#: there (held_force, with the contacts held through the first part) vanishes; held through the first part, open
#: through the second, no impulse at the sub-node
E = "E"
#: a held contact with friction that sticks through the first part of the step and slides from its sub-node on, which
#: it times: its friction force of the continuous motion there (contact_forces, with the contacts held and sticking
#: through the first part) reaches the cone
G = "G"
#: friction modes of a contact in a step: no friction force, sticking, sliding with a positive slip
#: velocity (ρ = −μ_f), sliding with a negative one (ρ = μ_f)
FREE, STICK, UP, DOWN = "-", "S", "U", "D"
#: ... and a ratio fixed by the frictional impact law (its tangential impulse over its normal one)
FIX = "X"
#: ... and, on a tangent plane (3-D), sliding against the slip's direction at the circular cone's edge
SLIDE = "L"

# The mode sets, named once (every test of a mode against a set uses one of these):
#: an impact at the sub-node (the step's impulse μ there): Newton's law, caught, fixed by the sequential law, Stronge's
SUB_IMPACT = (I, C, T, F, K)
#: ... or a held contact's slip turning there: the contacts that arrive at the sub-node, whose slip counts after it
AT_SUB = SUB_IMPACT + (W, G)
#: the contacts whose gap times the sub-node (it is on the surface there)
TIMES_SUB = (I, C, T, K)
#: the arrivals the march times by their gap alone (Newton's law or a catch)
GAP_TIMED = (I, C)
#: the contacts held through the first part of the step (their node force free, their sub-node gap closed)
HELD = (H, R, W, E, G)
#: the contacts closed at the step's next node
CLOSES = (H, C, K, W, G)
#: an impact at the step's first node (Newton's law there; P with its impulse fixed by the sequential law)
AT_NODE = (N, P)
#: impulses fixed by the sequential law (at the sub-node)
SEQUENTIAL = (F, T)
#: ... and at the node: the impacts exempt from Newton's law row
LAW_FIXED = SEQUENTIAL + (P,)
#: the contacts whose sub-node impulse μ is free (≥ 0)
FREE_IMPULSE = (H, I, C, K, W, G)
#: the contacts that may push at the sub-node in the search's cascade (an impulse shared by a timed arrival)
PUSHING = (I, C, H, R)
#: the contacts that must not penetrate at the sub-node
KEPT_OUT = PUSHING + (W, G)
#: friction modes that slide with a positive slip velocity (the force against it): up, and on a plane's cone
SLIDING_UP = (UP, SLIDE)



def releases(modes) -> np.ndarray:
    """Per contact, 1 where its sub-node impulse μ⁻ is its share of the first part's force
    (:meth:`ContactMechanics.release_row`): held until an impact's sub-node and released there (mode R in a step
    with an impact at its sub-node: I, C, T, F or K), held with its slip stopping or turning there (W), or sticking
    until it and sliding after (G): the friction force changes its law there, and the first part's end takes its own
    share, sticking or sliding as the first part did."""
    impact = any(m in SUB_IMPACT for m in modes)
    return np.array([float(impact and m == R or m in (W, G)) for m in modes])


def slips_after(modes) -> np.ndarray:
    """Per contact (the last axis of ``modes``), 1 where its sub-node slot's friction opposes the slip after the
    sub-node, 0 where it opposes the whole step's: the contacts that arrive there (an impact, caught or fixed by a
    law) or whose slip turns or starts there (W, G, :data:`AT_SUB`), and a contact held through a step whose
    sub-node holds another's impact.  Its sub-node impulse is then the impact's reaction, and Coulomb's law at an
    impact opposes the slip after it, as an arriving contact's does: the held corner of a rectangle that lands flat
    (μ = 0.01) slides at −0.64 before the other corner's plastic impact and at +0.023 after it, and the mean over
    the step's two parts, which the slot opposed, was −5e-4: no mode held with a scheme whose stages after the
    sub-node slide with the slip after it."""
    m = np.asarray(modes)
    impact = np.any(np.isin(m, SUB_IMPACT), axis=-1, keepdims=True)
    return (np.isin(m, AT_SUB) | (m == H) & impact).astype(float)


def turn_fraction(s0: float, s1: float):
    """Where in a step a slip turns, from the slip velocities (signed along the sliding direction) of the momenta
    ``p_k⁻`` and ``p_{k+1}⁻`` at its ends, or None where it does not turn in it.  Those momenta miss half of their
    node's friction impulse, so each is half a step's change ahead of the slip at its node: the slip's values
    at the nodes are ``s − Δ/2`` (``Δ = s0 − s1``)."""
    d = s0 - s1
    a, b = s0 - 0.5 * d, s1 - 0.5 * d
    if not (a > 0.0 and b <= 0.0):
        return None
    return a / (a - b)
