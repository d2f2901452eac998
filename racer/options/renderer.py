"""`--renderer auto|cpu|gpu`: which device draws the camera (`racer.shared.sim.scene.renderer`)."""

from __future__ import annotations

import click

from racer.shared.sim.scene.renderer import RENDERER_NAMES

RENDERER_HELP = (
    "Which device renders the camera: cpu (Mesa's llvmpipe), gpu (NVIDIA's EGL) or auto (the system's EGL order, "
    "the GPU first where one has EGL). An explicit MUJOCO_GL overrides it."
)

renderer_option = click.option(
    "--renderer", type=click.Choice(RENDERER_NAMES), default="auto", show_default=True, help=RENDERER_HELP
)
