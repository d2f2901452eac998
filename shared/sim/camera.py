"""Car cameras: offscreen MuJoCo rendering at 160×120 and DeepRacer's grayscale conversions (reference §8.1).

DeepRacer renders 640×480 and bilinear-resizes to 160×120. Here the camera renders 160×120 directly: with
software OpenGL the 640×480 frame costs 5-8x more (measured: ~13-20 ms vs ~2 ms per frame on the 2-core dev box),
and the picture differs only in anti-aliasing of thin lines.
"""

from __future__ import annotations

import numpy as np
from PIL import Image

from racer.shared.sim._mujoco import mujoco
from racer.shared.sim.gl import GLBackendError

IMAGE_WIDTH_PX = 160
IMAGE_HEIGHT_PX = 120
FULL_WIDTH_PX = 640
FULL_HEIGHT_PX = 480
"""Gazebo's camera resolution in DeepRacer."""
CENTER_CAMERA = "front_camera"
LEFT_CAMERA = "left_camera"
RIGHT_CAMERA = "right_camera"

_R = np.arange(256, dtype=np.float64) * 0.2989
_G = np.arange(256, dtype=np.float64) * 0.5870
_B = np.arange(256, dtype=np.float64) * 0.1140


def rgb_to_y(rgb: np.ndarray) -> np.ndarray:
    """RL Coach's RGB→Y filter then uint8 truncation: `uint8(0.2989 R + 0.5870 G + 0.1140 B)`.

    Table look-ups give the very same float64 products, summed in the same order, at a third of the cost.
    """
    return GrayConverter(rgb.shape[:2]).to_y(rgb)


class GrayConverter:
    """`rgb_to_y` with preallocated work buffers (the env converts one frame per step)."""

    def __init__(self, shape: tuple[int, ...]) -> None:
        self._sum = np.empty(shape, dtype=np.float64)
        self._term = np.empty(shape, dtype=np.float64)

    def to_y(self, rgb: np.ndarray) -> np.ndarray:
        _R.take(rgb[..., 0], out=self._sum)
        _G.take(rgb[..., 1], out=self._term)
        self._sum += self._term
        _B.take(rgb[..., 2], out=self._term)
        self._sum += self._term
        return self._sum.astype(np.uint8)


def rgb_to_l(rgb: np.ndarray) -> np.ndarray:
    """PIL's `convert('L')` (used for stereo images): `(19595 R + 38470 G + 7471 B + 0x8000) >> 16`."""
    value = rgb.astype(np.uint32)
    y = value[..., 0] * 19595 + value[..., 1] * 38470 + value[..., 2] * 7471 + 0x8000
    return (y >> 16).astype(np.uint8)


class CameraRenderer:
    """One offscreen renderer shared by the car's cameras.

    With `full_resolution`, frames are rendered at DeepRacer's 640×480 and bilinear-resized with PIL
    (`resize(..., resample=BILINEAR)`, as the SimApp's camera sensor) to the requested size.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        width_px: int = IMAGE_WIDTH_PX,
        height_px: int = IMAGE_HEIGHT_PX,
        full_resolution: bool = False,
    ) -> None:
        self._resize_to = (width_px, height_px) if full_resolution else None
        render_w, render_h = (FULL_WIDTH_PX, FULL_HEIGHT_PX) if full_resolution else (width_px, height_px)
        try:
            self._renderer = mujoco.Renderer(model, height=render_h, width=render_w)
        except (RuntimeError, ImportError, OSError, ValueError) as exc:
            import os

            raise GLBackendError(
                f"cannot create an offscreen OpenGL context with MUJOCO_GL={os.environ.get('MUJOCO_GL', '')!r}: {exc}. "
                "Use MUJOCO_GL=egl or MUJOCO_GL=osmesa (set before mujoco is imported)"
            ) from exc

    def rgb(self, data: mujoco.MjData, camera: str) -> np.ndarray:
        """(H, W, 3) uint8 image of a named camera."""
        self._renderer.update_scene(data, camera)
        rgb = self._renderer.render()
        if self._resize_to is not None:
            rgb = np.asarray(Image.fromarray(rgb).resize(self._resize_to, resample=Image.BILINEAR))
        return rgb

    def close(self) -> None:
        self._renderer.close()
