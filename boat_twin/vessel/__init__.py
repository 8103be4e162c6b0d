"""vessel package."""
