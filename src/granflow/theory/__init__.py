"""Theory toolkit: derivation of f from Z, condition checks (C1-C3, dissipation, equilibrium,
Z >= 0), Barker et al. (2015) window and the dispersion relation of the linearised model."""
