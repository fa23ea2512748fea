"""Physics blocks of the solver: each module assembles or advances one equation of the model.

For example :mod:`granflow.physics.pore_pressure` -- the implicit pore-gas-pressure equation (paper
eq. syst2b and its non-linear variant pressure-diffusion-nonlinear), its boundary conditions, and the
gas energy / Darcy dissipation of the energy identity (paper Theorem th1, MODEL.md §5).
"""
