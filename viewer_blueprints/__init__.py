"""mvtrack's viewer layouts, built in code for any number of cameras and pairs.

Each module has ``build(cameras, pairs) -> rerun.blueprint.Blueprint``; :data:`BLUEPRINTS`
maps a layout name (``mvtrack-view --layout NAME``) to its builder. Views refer only to the
entity paths of :mod:`mvtrack.viz.paths`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import rerun.blueprint as rrb

from viewer_blueprints import camera, overview, pairs

__all__ = ["BLUEPRINTS", "Builder", "build"]

Builder = Callable[[Sequence[str], Sequence[tuple[str, str]]], rrb.Blueprint]

BLUEPRINTS: dict[str, Builder] = {
    "overview": overview.build,
    "camera": camera.build,
    "pairs": pairs.build,
}
"""Layout name -> builder. ``overview`` is the default."""


def build(name: str, cameras: Sequence[str], pairs: Sequence[tuple[str, str]]) -> rrb.Blueprint:
    """The layout ``name`` for these cameras and pairs; a ValueError names the known layouts."""
    if name not in BLUEPRINTS:
        raise ValueError(f"unknown layout {name!r}: expected one of {', '.join(BLUEPRINTS)} "
                         "or a path to a saved .rbl file")
    return BLUEPRINTS[name](cameras, pairs)
