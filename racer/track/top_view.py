"""A rendered top view of a route in one world: what `racer track plot --rendered WORLD` draws."""

from __future__ import annotations

import numpy as np

from racer.shared.sim.scene._mujoco import mujoco
from racer.shared.sim.scene.mjcf import SceneSpec, build_model
from racer.shared.sim.scene.track_looks import look_for
from racer.shared.sim.scene.worlds import get_world
from racer.shared.sim.tracks.track import Track

TOP_VIEW_WIDTH_PX = 640
TOP_VIEW_HEIGHT_PX = 480


def render_top_view(track: Track, world: str = "base") -> np.ndarray:
    """(480, 640, 3) uint8: the floor, road and lines seen straight from above (orthographic), walls edge-on."""
    model = build_model(SceneSpec(track, get_world(world), 1.0 / 240.0, (("front_camera", 0.0),)))
    data = mujoco.MjData(model)
    data.qpos[2] = -10.0  # the car (drawn in a hidden group anyway) well below the floor
    mujoco.mj_forward(model, data)
    margin = look_for(track.name, world).field_margin_m
    lo = track.waypoints.reshape(-1, 3, 2).min(axis=(0, 1)) - margin
    hi = track.waypoints.reshape(-1, 3, 2).max(axis=(0, 1)) + margin
    span_x, span_y = hi - lo
    aspect = TOP_VIEW_WIDTH_PX / TOP_VIEW_HEIGHT_PX
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE.value
    camera.lookat[:] = (*(lo + hi) / 2, 0.0)
    camera.distance = 30.0
    camera.elevation = -90.0
    camera.azimuth = 90.0
    camera.orthographic = 1
    # With an orthographic camera, fovy is the height of the view in metres.
    model.vis.global_.fovy = 1.02 * max(span_y, span_x / aspect)
    with mujoco.Renderer(model, height=TOP_VIEW_HEIGHT_PX, width=TOP_VIEW_WIDTH_PX) as renderer:
        renderer.update_scene(data, camera)
        return renderer.render().copy()


__all__ = ["render_top_view"]
