"""`python -m research.frame_pairs`: fit each Gazebo frame's pose, render racer's frame there, compare policies."""

from research.frame_pairs.pairs import frame_pairs_command

frame_pairs_command(prog_name="python -m research.frame_pairs")
