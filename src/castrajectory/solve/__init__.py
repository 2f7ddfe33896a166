"""Solve: one NLP handed to Ipopt.

The Ipopt hand-off with element assembly and compiled element functions (``nlp``, ``assembly``,
``jit``), and the strategies that drive it for each family: coarse to fine and horizon windows
for trajectories (``trajectory``), the droplet (``droplet``), the contact penalty ladder
(``contact``); ``simulate`` is the one entry point for every trajectory method.
"""
