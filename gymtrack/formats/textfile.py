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


def what_is(value, empty: str = "nothing") -> str:
    """A value's kind in a user's words (``"a list"``, ``"the text 'abc'"``), for messages that
    would otherwise say ``got NoneType``; ``empty`` is what None (an empty file or field) reads as."""
    if value is None:
        return empty
    if isinstance(value, bool):
        return f"the boolean {value}"
    if isinstance(value, (int, float)):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the text {value[:40]!r}"
    if isinstance(value, (list, tuple)):
        return f"a list of {len(value)} item{'s' if len(value) != 1 else ''}"
    if isinstance(value, dict):
        return "a mapping"
    return f"a value of type {type(value).__name__}"
