"""Inspect: studies (convergence, work-precision, long horizon), errors against oracles and
pictures.  The only place matplotlib is imported (``plotting``: figures; ``animation``: animations)."""
