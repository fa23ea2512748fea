"""Exact and semi-analytic reference solutions the solver is verified against (MODEL.md §7,
NUMERICS.md §11), and what the validation studies share:

* :mod:`granflow.verification.defluidisation` -- the Fourier series of the 1-D defluidising column
  (pore-pressure diffusion, impermeable base, open top);
* :mod:`granflow.verification.sheared_layer` -- the logistic relaxation of the homogeneous sheared
  Drucker-Prager layer;
* :mod:`granflow.verification.bagnold` -- the steady Bagnold profile of a mu(I) layer on an incline
  (the ``inclined_layer`` case and validation/inclined_plane);
* :mod:`granflow.verification.convergence` -- Richardson extrapolation and the grid-convergence
  index of a sequence of levels (every mesh-convergence study);
* :mod:`granflow.verification.scripts` -- loading one validation script from another, the results
  files, and the scripts' one shape (``run(resolution, quick)``, ``main(argv)`` with ``--quick``).
"""
