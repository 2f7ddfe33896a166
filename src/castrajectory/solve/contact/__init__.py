"""Contact trajectories solved: the discrete march and its certificate, else the guess's branch and the penalty ladder.

The program is written by :class:`castrajectory.discretise.contact.transcription.ContactTranscription`
(its docstring states the transcription); :func:`solve_contact` solves it.  A system without a
contact term never reaches this module (:func:`castrajectory.solve.trajectory.solve_initial_value`
dispatches).

Solution strategy (chosen by the library)
-----------------------------------------
1. **The discrete march** (:func:`.march.discrete_march`).  An initial-value program is block
   lower-triangular in its steps, so it is solved step by step: each step's rows (node, sub-node,
   one complementarity pair per contact) by Newton, each contact in a mode (open, held, released,
   impact with Newton's law, caught) found by an active-set search on the most violated gap or
   multiplier.  A step that would need two impacts at different times is halved (the grid adapts to
   the impacts; at most ``ContactOptions.max_splits`` halvings), and contacts whose gaps agree to
   ``1e-9 ℓ`` at an impact take one simultaneous impact.  A bounce that does not clear the next
   node is caught there: the end of an accumulation that the grid does not resolve.
2. **The certificate** (:meth:`ContactNLP.solve_modes`, :meth:`castrajectory.solve.nlp.NLP.certify`).
   The march's modes decide every pair, so its branch of the program is a square feasibility
   problem; the whole system takes one Newton step from the marched point (removing the march's
   rounding drift), every row is checked with Ipopt's scaling, and the point is returned as a KKT
   point of that branch (status ``Rows_Verified``, multipliers and objective included).  If the
   check fails, Ipopt solves that branch from the marched point.
3. Otherwise (the march failed, or its branch did not converge), **the branch of the event-located
   guess** (:func:`.guess.event_guess`, RK4 flight with located impacts, on the uniform grid;
   :meth:`ContactNLP.solve_branch`) and then **the penalty continuation** from that guess
   (:meth:`ContactNLP.solve`): the one continuation loop, each rung recorded as a
   :class:`~castrajectory.result.HomotopyStep`.

Every setting of these stages is a field of :class:`.options.ContactOptions` (``solve_contact(...,
contact=ContactOptions(...))``).  The reported status is that of the last solve; ``attempts`` lists every stage.
"""
from ...discretise.contact.elements import ContactMechanics  # noqa: F401
from ...discretise.contact.transcription import COMPLEMENTARITY_TOL, PENALTY, TOUCH_TOL  # noqa: F401
from ...models.impact import simultaneous_impact  # noqa: F401
from .guess import event_guess  # noqa: F401
from .march import discrete_march  # noqa: F401
from .nlp import ContactNLP  # noqa: F401
from .options import ContactControlOptions, ContactOptions, MarchOptions  # noqa: F401
from .solution import ContactTrajectory, SubNodeImpact  # noqa: F401
from .strategy import solve_contact  # noqa: F401
