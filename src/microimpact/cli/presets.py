"""``microimpact presets``: the shipped presets."""

from __future__ import annotations

from . import _common as c

HELP = "list the shipped presets"


def cli_parse(sp):
    pass


def cli_action(args) -> int:
    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..scenario.file import PRESETS

    # deferred: the verb's library loads only when the verb runs (fast --help)
    from ..scenario.scenario import load_preset

    for name in PRESETS:
        print(f"{name:28s} {load_preset(name).description}")
    return c.EXIT_OK
