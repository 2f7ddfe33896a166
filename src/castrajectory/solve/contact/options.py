"""The contact solve's settings in one object (instead of module constants)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Tuple

from ...discretise.contact.transcription import PENALTY
from ...result import CERTIFICATE_TOL
from ...validation import InputError


def _integers(obj, names, least: int) -> None:
    """Refuse a field of ``names`` that is not an integer of at least ``least``."""
    for name in names:
        v = getattr(obj, name)
        if not isinstance(v, int) or isinstance(v, bool) or v < least:
            kind = "a positive integer" if least == 1 else "a non-negative integer"
            raise InputError(f"{name} must be {kind} (got {v!r})")


def _positive(obj, names) -> None:
    """Refuse a field of ``names`` that is not a positive finite number."""
    for name in names:
        v = getattr(obj, name)
        if not (isinstance(v, (int, float)) and not isinstance(v, bool) and 0.0 < float(v) < float("inf")):
            raise InputError(f"{name} must be positive and finite (got {v!r})")


@dataclass(frozen=True)
class MarchOptions:
    """Settings of the discrete march (:mod:`.march`, :mod:`.search`, :mod:`.step`), shared by the initial-value solve
    (``ContactOptions.march_options``) and the contact-implicit optimal control (``ContactControlOptions.march_options``,
    its guess and its certificate).

    * ``newton_iter``, ``step_tol``: Newton iterations of one step's solve, and the largest row residual accepted
      (each row divided by its largest derivative, relative to the size of the unknowns); ``runaway``: the largest
      growth of the unknowns from Newton's start that is still the step's root (Newton from the hopper's node ran to a
      root 1e10 away, a spurious branch of the friction rows);
    * ``chunk_steps``: steps that keep their modes (open or held) marched in one call, at most; ``chunk_newton``:
      Newton steps of each step of a chunk; ``chunk_tol``: a chunk's step is accepted at this scaled residual (its
      Jacobian is not equilibrated: its rounding sits near 1e-11 for a box held on two corners in the bowl, where
      1e-12 rejected 80 % of the chunks; the certificate's Newton step of the whole system polishes the point);
    * ``mode_rounds``: mode changes tried per step before the march gives up; ``friction_rounds``: friction-mode
      changes tried per solve of a step's normal modes; ``max_combinations``: combinations of modes tried at most
      when the greedy search fails;
    * ``simultaneous_gap``: a contact whose gap at an impact's sub-node is within this (times the length scale) takes
      part in that impact (a flat landing: one simultaneous impact);
    * ``impact_speed_steps``: a contact approaching faster than this many steps' worth of its normal acceleration,
      ``|J q̈| h``, arrives with an impact (resting contact approaches at about half a step's worth): touching at a
      step's first node it takes the impact there (mode N), and an answer lists its impulse as an impact; slower
      arrivals are the discrete form of persistent contact;
    * ``time_held_events``: the events of a held contact are timed inside their steps, at the steps' sub-nodes: a
      release where its normal force of the continuous motion reaches zero (mode E), a stick's end where its friction
      force reaches the cone (mode G), and a slip's stop or turn that the search had put at the step's node (mode W
      started from the node's slip; a slide's turn inside a step is timed either way).  Their times then have the
      scheme's order, where a release or a stick's end at a node or an untimed sub-node is first order.  The
      contact-implicit optimal control's rounds hold their own events, so its march leaves these untimed.
    """

    newton_iter: int = 30
    step_tol: float = 1e-12
    runaway: float = 1e6
    chunk_steps: int = 64
    chunk_newton: int = 3
    chunk_tol: float = 1e-10
    mode_rounds: int = 12
    friction_rounds: int = 8
    max_combinations: int = 256
    simultaneous_gap: float = 1e-9
    impact_speed_steps: float = 2.0
    time_held_events: bool = True

    def __post_init__(self):
        _integers(self, ("newton_iter", "chunk_steps", "chunk_newton", "mode_rounds", "friction_rounds",
                         "max_combinations"), 1)
        _positive(self, ("step_tol", "runaway", "chunk_tol", "simultaneous_gap", "impact_speed_steps"))


def _contact_ipopt() -> dict:
    return {"tol": 1e-10, "max_iter": 200, "bound_relax_factor": 0.0, "bound_push": 1e-8, "bound_frac": 1e-8,
            "slack_bound_push": 1e-8, "slack_bound_frac": 1e-8, "mu_init": 1e-8, "constr_mult_init_max": 0}


@dataclass(frozen=True)
class ContactOptions:
    """Settings of :func:`~castrajectory.solve.contact.solve_contact`; the defaults are the library's.

    * ``march``: solve by the discrete march and its certificate first (``False``: straight to the
      fallback, the event-located guess's branch and the penalty continuation);
    * ``max_splits``: halvings of a step where impacts crowd (the finest step is ``h / 2**max_splits``);
    * ``certify_tol``: scaled row violation and stationarity backward error within which the marched
      point is certified as a KKT point of its branch;
    * ``branch_max_iter``: Ipopt's iteration budget of a decided branch (the march's or the guess's);
    * ``penalties``: the rungs ρ of the penalty continuation, each warm-started from the last;
    * ``march_options``: the march's own settings (:class:`MarchOptions`);
    * ``ipopt``: Ipopt's options of every contact solve (the optimal control's start from them too):
      ``bound_relax_factor`` 0 (impulses, forces and gaps stay exactly non-negative), tiny bound and slack pushes so
      guesses on the ground are not pushed away; ``branch_pivtol``: MUMPS' pivot tolerance of a decided branch (a
      branch that needs more than a few iterations is a wrong decision, and restoration on its degenerate KKT
      matrix cost 2 s an iteration with MUMPS' default, 0.46 s with 1e-8, on a 4000-step block drop);
    * the event-located guess (the fallback's): ``simultaneous_tol``, contacts whose gaps close within this (times
      the length scale) of each other at a located crossing take one simultaneous impact; ``lookahead_catch``, steps
      looked ahead after a bounce for the rocking-accumulation catch; ``guess_chunk``, steps of free flight
      integrated per call;
    * the answer's report: ``impulse_tol``, an impulse above this fraction of the momentum scale is listed as an
      impact; ``caught_law``, an impact is *caught* where Newton's law misses by more than this fraction of the
      arrival speed; ``elastic_loss_tol``, an elastic scene (e = 1) whose energy falls by more than this fraction
      is reported with a warning.
    """

    march: bool = True
    max_splits: int = 20
    certify_tol: float = 1e-9
    branch_max_iter: int = 30
    penalties: Tuple[float, ...] = PENALTY
    march_options: MarchOptions = field(default_factory=MarchOptions)
    ipopt: dict = field(default_factory=_contact_ipopt)
    branch_pivtol: float = 1e-8
    simultaneous_tol: float = 1e-9
    lookahead_catch: int = 3
    guess_chunk: int = 64
    impulse_tol: float = 1e-6
    caught_law: float = 1e-6
    elastic_loss_tol: float = 1e-6

    def __post_init__(self):
        _positive(self, ("branch_pivtol", "simultaneous_tol", "impulse_tol", "caught_law", "elastic_loss_tol"))
        _integers(self, ("lookahead_catch", "guess_chunk"), 1)
        if not isinstance(self.max_splits, int) or not 0 <= self.max_splits <= 40:
            raise InputError(f"max_splits must be an integer in [0, 40] (got {self.max_splits!r})")
        if not 0.0 < float(self.certify_tol) < 1e-3:
            raise InputError(f"certify_tol must be in (0, 1e-3) (got {self.certify_tol!r})")
        if not isinstance(self.branch_max_iter, int) or self.branch_max_iter < 0:
            raise InputError(f"branch_max_iter must be a non-negative integer (got {self.branch_max_iter!r})")
        pen = tuple(float(p) for p in self.penalties)
        if not pen or any(not p > 0.0 or p != p or p == float("inf") for p in pen) or list(pen) != sorted(pen):
            raise InputError(f"penalties must be finite, positive and increasing (got {self.penalties!r})")
        object.__setattr__(self, "penalties", pen)


def _ipopt_base() -> dict:
    return {"tol": 1e-8, "max_iter": 3000, "mumps_pivtol": 1e-8, "mu_init": 1e-1, "mu_strategy": "adaptive",
            "bound_push": 1e-2, "bound_frac": 1e-2, "slack_bound_push": 1e-2, "slack_bound_frac": 1e-2}


def _ipopt_warm() -> dict:
    return {"warm_start_init_point": "yes", "mu_init": 1e-6, "warm_start_bound_push": 1e-9,
            "warm_start_mult_bound_push": 1e-9, "warm_start_bound_frac": 1e-9, "warm_start_slack_bound_push": 1e-9,
            "warm_start_slack_bound_frac": 1e-9}


def _ipopt_near() -> dict:
    return {"mu_init": 1e-6, "bound_push": 1e-8, "bound_frac": 1e-8, "slack_bound_push": 1e-8,
            "slack_bound_frac": 1e-8}


@dataclass(frozen=True)
class ContactControlOptions:
    """Settings of the contact-implicit optimal control (:func:`~castrajectory.solve.contact.control.solve_contact_control`,
    ``OptimalControl.solve(contact=...)``); the defaults are the library's.  Each field says what it controls; why each
    default sits where it does, with the measurements and the commands that reproduce them, is in ``docs/notes.md``
    ("Contact-implicit optimal control: the settings").

    The solve is one loop (:mod:`.control`): a round solves the program on a :class:`~.branch.Branch` from the first
    of its start policies that converges, the next branch is read from the answer, and every answer is certified.

    Ipopt (each on top of the contact program's own options, ``ContactOptions.ipopt``):

    * ``ipopt``: every solve's options; an adaptive barrier from 0.1 with bounds pushed by 1e-2, since the first
      guess is a motion far from the optimum; ``tol`` 1e-8;
    * ``warm_ipopt``: a round started from the last round's primal-dual point: a small barrier, nothing pushed;
    * ``near_ipopt``: the first round on a finer grid of the ladder, from the coarser answer's march: a small barrier,
      nothing pushed off its bounds.

    The loop:

    * ``starts``: the start policies of a round, tried in this order until one converges (:data:`.policies.STARTS`
      names them: ``"near"`` the first round on a finer grid of the ladder, from the coarser answer's march;
      ``"warm"`` a later round from the last answer's primal-dual point; ``"from_last"`` the last answer itself where
      the round restarted steps; ``"cold"`` the homotopy's barrier, always last);
    * ``penalties``: the rungs ρ of the penalty ladder, each warm-started from the last;
    * ``complementarity_target``: the ladder climbs until the scaled complementarity residual is at most this (a held
      contact's gap is then below the certificate march's touch tolerance);
    * ``iteration_budget``: Ipopt iterations of one solve in all (rounds, rungs, branches, coarser grids), where the run
      sets no budget of its own (``--max-iter``);
    * ``timing_rounds``: rounds whose events are read from the last answer, at most; ``move_rounds``: rounds beyond
      them while an event pinned at its window's edge moves one step per round;
    * ``restart_iter``: iterations of a round's warm solve after steps were restarted from their one-step marches,
      before it starts again from the last answer; ``continuation_iter``: iterations of one step of ``keep_modes``'
      continuation of the end conditions;
    * ``ladder_max``: a grid of more steps starts from the answer on half as many (the ladder of grids);
    * ``node_force``: a node force above this fraction of the largest closes its node when events are read;
    * ``edge``: a timed sub-node stays this fraction of its step from the step's nodes (inside the march's window);
      ``near_edge``, ``b_tol``: a sub-node this close to its window's edge whose bound multiplier exceeds ``b_tol``
      (relative to the cost's scale) is held there (pinned); ``b_tol`` is also the B-stationarity proxy's tolerance;
    * ``across_rounds``: certified answers with a pinned event moved across its node, one after another, at most;
    * ``elastic_weight``: the end conditions' weight in the elastic mode's cost (a failed solve with a given end state
      is solved again with the end in the cost, then from that answer);

    The certificate and its branch re-solves:

    * ``certificate_tol``: every step of the controls, marched from the answer's own node, lands on the next node to
      this (relative);
    * ``resolve_rounds``, ``resolve_contracting``: branch re-solves of an answer that does not certify: at most
      ``resolve_rounds``, and up to ``resolve_contracting`` while each certificate halves the last;
    * ``branch_small_iter``: iterations of a branch solve's first try, from its march with a small barrier;
    * ``march_options``: the march's own settings (:class:`MarchOptions`: the guess's march and the certificate's).

    >>> import castrajectory as ct
    >>> o = ct.ContactControlOptions(starts=("warm", "cold"), certificate_tol=1e-8)
    >>> o.starts, o.penalties[-1], o.timing_rounds
    (('warm', 'cold'), 1000000.0, 6)
    >>> ct.ContactControlOptions(starts=("warm",))
    Traceback (most recent call last):
        ...
    castrajectory.validation.InputError: starts must name start policies, the last one 'cold' (got ('warm',))
    """

    ipopt: dict = field(default_factory=_ipopt_base)
    warm_ipopt: dict = field(default_factory=_ipopt_warm)
    near_ipopt: dict = field(default_factory=_ipopt_near)
    starts: Tuple[str, ...] = ("near", "warm", "from_last", "cold")
    penalties: Tuple[float, ...] = (1e3, 1e4, 1e5, 1e6)
    complementarity_target: float = 1e-11
    iteration_budget: int = 7000
    timing_rounds: int = 6
    move_rounds: int = 6
    restart_iter: int = 500
    continuation_iter: int = 150
    ladder_max: int = 32
    node_force: float = 1e-6
    edge: float = 1e-3
    near_edge: float = 1e-2
    b_tol: float = 1e-6
    across_rounds: int = 8
    elastic_weight: float = 1.0
    certificate_tol: float = CERTIFICATE_TOL
    resolve_rounds: int = 3
    resolve_contracting: int = 6
    branch_small_iter: int = 500
    march_options: MarchOptions = field(default_factory=lambda: MarchOptions(time_held_events=False))

    def __post_init__(self):
        # (the names themselves are checked against the registry, .policies.STARTS, when a solve starts)
        if not self.starts or not all(isinstance(x, str) for x in self.starts) or self.starts[-1] != "cold":
            raise InputError(f"starts must name start policies, the last one 'cold' (got {self.starts!r})")
        object.__setattr__(self, "starts", tuple(self.starts))
        pen = tuple(float(p) for p in self.penalties)
        if not pen or any(not 0.0 < p < float("inf") for p in pen) or list(pen) != sorted(pen):
            raise InputError(f"penalties must be finite, positive and increasing (got {self.penalties!r})")
        object.__setattr__(self, "penalties", pen)
        if not isinstance(self.timing_rounds, int) or self.timing_rounds < 1:
            raise InputError(f"timing_rounds must be a positive integer (got {self.timing_rounds!r})")
        _integers(self, ("iteration_budget", "timing_rounds", "move_rounds", "restart_iter", "continuation_iter",
                     "ladder_max", "across_rounds", "resolve_rounds", "resolve_contracting", "branch_small_iter"), 0)
        _positive(self, ("complementarity_target", "node_force", "b_tol", "certificate_tol", "elastic_weight"))
        if not 0.0 < float(self.edge) < float(self.near_edge) < 0.5:
            raise InputError(f"edge and near_edge must satisfy 0 < edge < near_edge < 0.5 (got {self.edge!r}, "
                             f"{self.near_edge!r})")
