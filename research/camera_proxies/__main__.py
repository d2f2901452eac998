"""`python -m research.camera_proxies`: racer's frames against DeepRacer's Gazebo frames, per world."""

from research.camera_proxies.camera import camera_command

camera_command(prog_name="python -m research.camera_proxies")
