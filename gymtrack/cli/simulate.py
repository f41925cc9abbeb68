"""gymtrack CLI: simulate commands."""
