"""gymtrack CLI: info commands."""
