"""Reference implementations the compiled kernels are tested against (never run in production).

The vectorised numpy versions the kernels of :mod:`gymtrack.tracking._kernels` replaced, the
literal one-merge-at-a-time Algorithm 1, and the plane kernel's steps one at a time. The test
modules import them as ``from reference.<stage> import ...`` (pytest puts ``tests/`` on the
import path, as for ``conftest``).
"""
