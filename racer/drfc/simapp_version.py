"""DR_SIMAPP_VERSION -> the racer generation that stands in for that SimApp (racer.shared.sim.generations.catalog).

DRfC runs the SimApp image `DR_SIMAPP_SOURCE:DR_SIMAPP_VERSION` (deepracer-for-cloud 2eb1a1f1 bin/activate.sh; its
bin/init.sh fills in `<version>-<cpu|gpu>` from defaults/dependencies.json, 6.0.4 there). Versions up to 5.x are the
ROS 1 / Gazebo classic SimApp (`simapp5`), 6.x the ROS 2 / gz-sim one (`simapp6`).
"""

from __future__ import annotations

import re

from racer.drfc.shell_env import Assignment

__all__ = ["simapp_generation"]


def simapp_generation(assignment: Assignment | None) -> tuple[str | None, list[str]]:
    """(the generation, notes); None when the version is unset or not one racer knows (racer's default then)."""
    if assignment is None or not assignment.value:
        return None, []
    match = re.match(r"v?(\d+)\.", assignment.value)
    major = int(match.group(1)) if match else None
    if major is not None and major <= 5:
        return "simapp5", []
    if major == 6:
        return "simapp6", []
    return None, [
        f"{assignment.where}: DR_SIMAPP_VERSION={assignment.value}: not a SimApp version racer stands in for "
        f"(up to 5.x: simapp5, 6.x: simapp6); racer's default generation trains"
    ]
