"""Mutated documents for the readers' property tests (hypothesis): a valid JSON-like document with
1-3 values replaced, removed or appended to, so that a reader must either parse it correctly or
raise the project's InputError naming the file and the field."""

from __future__ import annotations

import copy

from hypothesis import strategies as st


def value_paths(node, prefix=()):
    """Every path (tuple of keys / indices) into a JSON-like document, the root first."""
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from value_paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from value_paths(v, prefix + (i,))


@st.composite
def mutated_doc(draw, base, values):
    """``base`` with 1-3 values replaced, removed or appended to, new values drawn from ``values``."""
    doc = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(list(value_paths(doc))))
        if not path:
            doc = draw(values)
            continue
        parent = doc
        for k in path[:-1]:
            parent = parent[k]
        action = draw(st.sampled_from(["replace", "replace", "delete", "append"]))
        if action == "delete":
            del parent[path[-1]]
        elif action == "append" and isinstance(parent[path[-1]], list):
            parent[path[-1]].append(draw(values))
        else:
            parent[path[-1]] = draw(values)
    return doc
