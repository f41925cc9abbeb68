"""The project's own error types.

Every problem with what a user handed in (a calibration, a detection file, a scene) is raised
as a :class:`GymtrackError` subclass whose message names the file, the line or field, and what
is wrong, so a user never has to read a traceback from deep inside numpy or yaml.
"""

from __future__ import annotations

from pathlib import Path


class GymtrackError(Exception):
    """Base class of every error gymtrack raises on purpose."""


class InputError(GymtrackError, ValueError):
    """Bad user input: names the source (file), the place (line or field) and the problem.

    Parameters
    ----------
    problem:
        What is wrong, in words a user understands.
    source:
        The file (or other source such as ``"cameras.yaml"``) the input came from.
    line:
        1-based line number inside ``source``, when the input is line-oriented.
    field:
        Dotted name of the field inside ``source`` (``"cameras[2].R"``), when it is structured.
    """

    def __init__(
        self,
        problem: str,
        *,
        source: str | Path | None = None,
        line: int | None = None,
        field: str | None = None,
    ) -> None:
        self.problem = problem
        self.source = None if source is None else str(source)
        self.line = line
        self.field = field
        where = []
        if self.source is not None:
            where.append(self.source)
        if line is not None:
            where.append(f"line {line}")
        if field is not None:
            where.append(f"field '{field}'")
        super().__init__(f"{': '.join(where)}: {problem}" if where else problem)

    def located(self, source: str | Path | None = None, field_prefix: str | None = None) -> "InputError":
        """A copy of this error with the source and/or a field prefix filled in."""
        field = self.field
        if field_prefix:
            field = f"{field_prefix}.{field}" if field else field_prefix
        err = type(self)(self.problem, source=source if source is not None else self.source, line=self.line, field=field)
        return err


class CalibrationError(InputError):
    """A camera calibration that cannot be used (not a rotation, singular K, wrong shapes...)."""


class DetectionFormatError(InputError):
    """A malformed detection file or box."""


class SceneError(InputError):
    """An invalid ``scene.yaml``."""


class RoutineError(InputError):
    """A routine folder that is inconsistent (missing files, cameras without detections...)."""


class GymtrackWarning(UserWarning):
    """Something a user should know about their input or a result (a camera far from the origin,
    a camera that goes silent, a run with no tracks). The command line prints these as one-line
    messages; ``--strict`` makes them fatal."""
