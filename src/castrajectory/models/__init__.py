"""Describe: what the physics is.

Lagrangian systems and their terms (``mechanics``), the pendulum family (``pendulum``), the
rigid body, its impact law and the contact scenes (``collision``), the droplet (``droplet``).
Each model carries its analytic oracle.  Nothing here knows about grids or solvers.
"""
