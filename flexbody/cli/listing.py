"""``flexbody list``: the built-in scenes."""

from __future__ import annotations


def cmd_list(args) -> int:
    """``flexbody list``: one line per built-in scene."""
    from flexbody.scenes.registry import SCENES
    for name, entry in SCENES.items():
        print(f"{name:24s} {entry.summary}")
    return 0
