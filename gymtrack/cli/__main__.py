"""``python -m gymtrack.cli``: the ``gymtrack`` command (no part of the paper)."""

from gymtrack.cli import main

main()
