"""gymtrack CLI: benchmark commands."""
