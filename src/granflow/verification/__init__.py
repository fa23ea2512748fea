"""Exact and semi-analytic reference solutions the solver is verified against (MODEL.md §7,
NUMERICS.md §11), e.g. :mod:`granflow.verification.defluidisation` -- the Fourier series of the 1-D
defluidising column (pore-pressure diffusion, impermeable base, open top).
"""
