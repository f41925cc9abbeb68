"""``gymtrack benchmark --methods``: comma-separated and repeated forms both count every method."""

import pytest

from gymtrack.cli.benchmark import _methods
from gymtrack.errors import InputError


def test_repeated_and_comma_separated_methods_all_count():
    assert _methods(["cascade+", "oracle"]) == ["cascade+", "oracle"]
    assert _methods(["cascade+,oracle", "cascade"]) == ["cascade+", "oracle", "cascade"]
    assert _methods(["oracle", "oracle"]) == ["oracle"]
    assert _methods(None) == ["cascade", "cascade+", "triangulation", "plane", "mvpt", "oracle"]


def test_an_unknown_method_is_named():
    with pytest.raises(InputError, match="'kalman'"):
        _methods(["cascade+", "kalman"])
