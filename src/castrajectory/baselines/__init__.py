"""Time-stepping baselines, kept for comparison only: RK4, implicit Euler, the marched variational
integrator, Moreau-Jean, and the CVODES reference."""
