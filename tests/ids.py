"""Test ids in ASCII: tools that hand pytest's listed ids back to it (mutmut,
benchmarks/mutation_score.py) do not round-trip its escaped non-ASCII ids
(``'\\xb5m'`` is then "not found")."""

from __future__ import annotations


def ascii_id(text: str) -> str:
    """`text` with each non-ASCII character replaced by ``?``."""
    return text.encode("ascii", "replace").decode()
