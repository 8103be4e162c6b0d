"""The names of the registered scenarios, in a module free of heavy imports (``boat-twin simulate --help`` lists
them at once). :data:`boat_twin.vessel.scenarios.SCENARIOS` registers a factory under each (test_vessel checks
that the two agree)."""

SCENARIO_NAMES = ("thrust-steps", "accel-stop", "zigzag-20-20", "zigzag-10-10", "turning-circle",
                  "turning-circle-engine", "crash-stop", "random")
"""Scenario names the command line accepts, in the order --help lists them."""
