"""cable package."""
