"""`--checkpoint`: which of a stored model's checkpoints a command reads (`racer evaluate`, `racer model explain`)."""

from __future__ import annotations

import click

checkpoint_option = click.option(
    "--checkpoint",
    default="best",
    show_default=True,
    help="best, last, or a checkpoint name such as 3_Step-1234.ckpt (DeepRacer's EVAL_CHECKPOINT).",
)
