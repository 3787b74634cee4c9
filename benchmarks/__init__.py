"""The project's measurement scripts (not in the wheel): each runs as ``python -m benchmarks.NAME``
from the repository root, writes its report under ``results/`` and names its command there.

:func:`benchmarks.common.scripts` lists them with what each measures.
"""
