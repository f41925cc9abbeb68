"""gymtrack CLI: track commands."""
