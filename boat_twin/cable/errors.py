"""The cable solver's failure: no equilibrium found. Reported like bad input (one line, exit code 2)."""

from boat_twin.errors import InputError


class CableSolveError(InputError):
    """No equilibrium for the given case (never a silent wrong answer); the message says which and why."""
