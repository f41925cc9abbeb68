"""Reading a user's text file with errors that name it (shared by every reader of :mod:`gymtrack.formats`)."""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError


def read_text(path: Path, error: type[InputError] = InputError) -> str:
    """The UTF-8 text of ``path``; a missing file, a folder or undecodable bytes raise ``error``
    naming the file."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise error("file not found", source=path) from None
    except IsADirectoryError:
        raise error("is a folder, expected a file", source=path) from None
    except UnicodeDecodeError:
        raise error("not UTF-8 text", source=path) from None
