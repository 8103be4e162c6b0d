"""``python -m boat_twin.cli``: the ``boat-twin`` command."""

from boat_twin.cli import main

raise SystemExit(main())
