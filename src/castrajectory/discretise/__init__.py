"""Discretise: how a model becomes finitely many unknowns.

The named program (``program``: unknowns, rows, element families), discrete Lagrangians with
their order, DEL residuals and Legendre transforms (``lagrangians``), and the transcriptions of
each family: the whole trajectory (``trajectory``), the droplet (``droplet``), contact (``contact/``).
Nothing here calls Ipopt.
"""
