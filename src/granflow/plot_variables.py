"""Names of the variables ``granflow plot`` draws, in a module without NumPy so that the CLI
parser (``granflow --help``) can list them without importing the plotting stack."""

PLOT_VARIABLES = ("phi", "u", "w", "p", "p_f", "S", "speed")
"""The cell-centred NetCDF fields of output.nc and the derived granular speed."""
SPEED = "speed"
"""The derived variable |u| = sqrt(u^2 + w^2) [m s-1]."""
