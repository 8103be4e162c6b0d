"""ident package."""
