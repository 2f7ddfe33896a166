"""Contact trajectories solved: the event-located guess, the penalty ladder, held catches and windows.

The program is written by :class:`castrajectory.discretise.contact.transcription.ContactTranscription`
(its docstring states the transcription); :func:`solve_contact` solves it.  A system without a
contact term never reaches this module (:func:`castrajectory.solve.trajectory.solve_initial_value`
dispatches).

Solution strategy (chosen by the library)
-----------------------------------------
1. **Event-located guess.**  The smooth equations of motion are integrated
   (RK4) from the start; every gap crossing is located by bisection, the
   impact law of :func:`castrajectory.models.collision.impact_law` is applied
   there and the flight continues.  The sub-node of that step is placed at the
   crossing with the impact's ``μ``; a second crossing in the rest of that step gets a second
   impact and sub-node (whole solve only).  A slow arrival (normal speed below
   ``v_z = max(2, 1/e) a h``, ``a`` the scene's acceleration scale) while every
   contact of the body moves slowly along the normal is caught instead (the
   accumulation point of Zeno bouncing): a plastic impact, after which the
   caught contacts are *held* (each RK4 step projected back onto ``φ_j = 0``,
   ``J_j v = 0``: the body rests or slides) until the free flight would lift one off.
2. **The branch the guess identifies** (:meth:`ContactNLP.solve_branch`): every complementarity
   pair decided by the guess (touching contacts keep their gap rows as equalities, open ones have no
   force or impulse; Newton's law exact at the guess's bounces), a nearly square NLP whose solution is
   a solution of the complementarity problem.  From the event-located guess it converges in a few
   iterations; a wrong decision stops it within :data:`BRANCH_IPOPT`'s budget.
3. Otherwise the **whole solve** of all ``N`` steps from that guess with the penalty ladder.
   If it fails where the residual's unweighted check of Newton's law rejects
   the last point Ipopt solved (a *loophole*: the law's weight small there, or
   the waiver used for a catch that lifts off again), those laws are weighted
   by ``φ(q_{k+2})/ℓ`` as well (a catch must hold) and the whole solve restarts
   from the guess (at most :data:`HELD_ROUNDS` rounds; :meth:`ContactNLP.loopholes`).
4. If that fails too, **horizon windows** (small contact NLPs marched over the
   horizon, each with its own event-located guess and iteration budget, its branch first) whose
   assembled solution starts a final whole solve (its branch first).  If every window converged
   but that final solve does not, the assembled point itself is the answer
   provided it satisfies the whole NLP (scaled rows within
   :data:`ASSEMBLED_ROW_TOL`, residual within :data:`COMPLEMENTARITY_TOL`),
   reported with the status ``Assembled_From_Windows``.

Otherwise the reported status is that of the last whole-trajectory solve.
"""
from ...discretise.contact.elements import ContactMechanics  # noqa: F401
from ...discretise.contact.transcription import COMPLEMENTARITY_TOL, PENALTY, TOUCH_TOL  # noqa: F401
from ...models.impact import simultaneous_impact  # noqa: F401
from .guess import GUESS_CHUNK, SIMULTANEOUS_TOL, event_guess  # noqa: F401
from .nlp import BRANCH_IPOPT, CONTACT_IPOPT, ContactNLP  # noqa: F401
from .solution import IMPACT_SPEED_STEPS, IMPULSE_TOL, ContactTrajectory, SubNodeImpact  # noqa: F401
from .strategy import (  # noqa: F401
    ASSEMBLED_ROW_TOL, HELD_ROUNDS, MIN_WINDOW, WINDOW_MAX_ITER, WINDOWS_MAX_ITER_TOTAL, solve_contact)
