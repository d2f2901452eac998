"""Car cameras: offscreen MuJoCo rendering at 160×120 and DeepRacer's grayscale conversions (deepracer-simapp v5.3.3
`bundle/markov/sensors/sensors_rollout.py`).

DeepRacer renders 640×480 and bilinear-resizes to 160×120. Here the camera renders 160×120 directly: with
software OpenGL the 640×480 frame costs several times more, and the picture differs only in anti-aliasing of thin
lines, which the direct frame imitates (shared/sim/README.md, "The camera").
"""

from __future__ import annotations

import functools
import weakref

# mujoco first: for MUJOCO_GL=osmesa it sets PYOPENGL_PLATFORM, which PyOpenGL reads once, at its first import.
from racer.shared.sim.scene._mujoco import mujoco

# isort: split
import cv2
import numpy as np
from OpenGL import GL
from PIL import Image

from racer.shared.sim.scene.gl import GLBackendError, chosen_backend

IMAGE_WIDTH_PX = 160
IMAGE_HEIGHT_PX = 120
FULL_WIDTH_PX = 640
FULL_HEIGHT_PX = 480
"""Gazebo's camera resolution in DeepRacer."""
CENTER_CAMERA = "front_camera"
LEFT_CAMERA = "left_camera"
RIGHT_CAMERA = "right_camera"


def rgb_to_y(rgb: np.ndarray) -> np.ndarray:
    """RL Coach's RGB→Y filter then uint8 truncation: `uint8(0.2989 R + 0.5870 G + 0.1140 B)`."""
    return GrayConverter(rgb.shape[:2]).to_y(rgb)


@functools.cache
def _luma_table() -> np.ndarray:
    """Y of every colour, indexed by R | G << 8 | B << 16 (16 MiB, read-only, built once per process in ~0.15 s).

    Each entry is RL Coach's float64 formula, products summed in its order, so a look-up is the formula itself.
    """
    green_blue = np.arange(1 << 16)
    green_term = 0.5870 * (green_blue & 0xFF).astype(np.float64)
    blue_term = 0.1140 * (green_blue >> 8).astype(np.float64)
    table = np.empty(1 << 24, dtype=np.uint8)
    for red in range(256):
        table[red | (green_blue << 8)] = ((0.2989 * red + green_term) + blue_term).astype(np.uint8)
    table.flags.writeable = False
    return table


class GrayConverter:
    """`rgb_to_y` for frames of one shape, at one table look-up per pixel (the env converts a frame per step).

    The frame is copied into a buffer one byte longer than the pixels, so that a little-endian uint32 view with a
    3-byte stride reads each pixel's R, G, B (plus the next pixel's R, masked off) as one table index.
    """

    def __init__(self, shape: tuple[int, ...]) -> None:
        self._shape = tuple(shape[:2])
        pixels = self._shape[0] * self._shape[1]
        self._bytes = np.zeros(3 * pixels + 1, dtype=np.uint8)
        self._words = np.ndarray((pixels,), dtype="<u4", buffer=self._bytes, strides=(3,))
        self._index = np.empty(pixels, dtype=np.uint32)
        self._table = _luma_table()

    def to_y(self, rgb: np.ndarray) -> np.ndarray:
        if rgb.shape != (*self._shape, 3) or rgb.dtype != np.uint8:
            raise ValueError(f"expected a {self._shape} x 3 uint8 frame, got {rgb.shape} {rgb.dtype}")
        self._bytes[:-1].reshape(*self._shape, 3)[...] = rgb
        np.bitwise_and(self._words, 0xFFFFFF, out=self._index)
        return self._table.take(self._index).reshape(self._shape)


def rgb_to_l(rgb: np.ndarray) -> np.ndarray:
    """PIL's `convert('L')` (used for stereo images): `(19595 R + 38470 G + 7471 B + 0x8000) >> 16`."""
    value = rgb.astype(np.uint32)
    y = value[..., 0] * 19595 + value[..., 1] * 38470 + value[..., 2] * 7471 + 0x8000
    return (y >> 16).astype(np.uint8)


TEXTURE_LOD_BIAS = -1.0
"""Mip level offset for the direct frame. GL picks a texture's mip level from the longer side of a pixel's
footprint, which on a road seen at a grazing angle blurs it across; one level finer keeps lines and dashes as sharp
as DeepRacer's 640x480 + resize. (Anisotropic filtering would do it properly but costs llvmpipe several times the
frame.)"""
RESIZE_KERNEL = np.array([0.125, 0.75, 0.125], dtype=np.float32)
"""Separable filter applied to the direct frame: the part of DeepRacer's 4x bilinear downscale (a triangle one
output pixel wide) that a point-sampled pixel misses; it softens geometric edges such as the walls' foot."""


def _sharpen_texture_filter(context: mujoco.MjrContext, lod_bias: float) -> None:
    """Set the mip level bias of the context's 2D textures (MuJoCo uploads them mip-mapped, trilinear)."""
    for texture_id in np.asarray(context.texture)[: context.ntexture]:
        GL.glBindTexture(GL.GL_TEXTURE_2D, int(texture_id))
        GL.glTexParameterf(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_LOD_BIAS, lod_bias)
    GL.glBindTexture(GL.GL_TEXTURE_2D, 0)


def _release_gl(resources: list) -> None:
    """Free a renderer's MjrContext with its own GL context current, then the GL context.

    A dropped renderer must not free its GL objects in whichever context happens to be current: the names of
    framebuffers and textures repeat across contexts, so that would delete another renderer's framebuffer
    (`GLError 1286 invalid framebuffer operation` at its next frame). `resources` is [gl_context, mjr_context];
    both are popped so nothing is left to a later, context-less destructor.
    """
    gl, context = resources
    resources.clear()
    if gl is None:
        return
    if context is not None:
        with gl.as_current():
            context.free()
            del context
    gl.free()


class CameraRenderer:
    """One offscreen GL context, scene and frame buffer shared by the car's cameras.

    A thin version of `mujoco.Renderer` for the hot path: fixed cameras resolved once, a preallocated pixel
    buffer, a scene sized for this model. The returned RGB array is that buffer: it is overwritten by the next
    call, so callers copy what they keep. With `full_resolution`, frames are rendered at DeepRacer's 640×480
    and bilinear-resized with PIL (`resize(..., resample=BILINEAR)`, as the SimApp's camera sensor).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        width_px: int = IMAGE_WIDTH_PX,
        height_px: int = IMAGE_HEIGHT_PX,
        full_resolution: bool = False,
        antialias: bool = True,
        front_groups: tuple[int, ...] = (),
    ) -> None:
        """`front_groups`: geom groups drawn before the others, for opaque objects standing on the road (race
        objects): drawn first, they hide the road behind them from the depth test, so llvmpipe skips that road's
        texture work; the pixels are the same as in MuJoCo's order (tested)."""
        self._model = model
        self._resize_to = (width_px, height_px) if full_resolution else None
        render_w, render_h = (FULL_WIDTH_PX, FULL_HEIGHT_PX) if full_resolution else (width_px, height_px)
        if render_w > model.vis.global_.offwidth or render_h > model.vis.global_.offheight:
            raise ValueError(f"render size {render_w}x{render_h} exceeds the model's offscreen buffer")
        self._gl = None
        self._context = None
        try:
            self._gl = mujoco.GLContext(render_w, render_h)
            self._gl.make_current()
            self._context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150.value)
        except (RuntimeError, ImportError, OSError, AttributeError) as exc:
            _release_gl([self._gl, self._context])
            raise GLBackendError(
                f"cannot create an offscreen OpenGL context with MUJOCO_GL={chosen_backend()!r}: {exc}. "
                "Use MUJOCO_GL=egl or MUJOCO_GL=osmesa (set before mujoco is imported)"
            ) from exc
        # Freed with its own context current, whether by close(), garbage collection or interpreter exit.
        self._release = weakref.finalize(self, _release_gl, [self._gl, self._context])
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self._context)
        self._filter_frame = antialias and not full_resolution
        if self._filter_frame:
            _sharpen_texture_filter(self._context, TEXTURE_LOD_BIAS)
        self._scene = mujoco.MjvScene(model=model, maxgeom=max(64, 2 * model.ngeom))
        self._option = mujoco.MjvOption()
        self._front_option: mujoco.MjvOption | None = None
        if front_groups:
            self._front_option = mujoco.MjvOption()
            for group in range(len(self._option.geomgroup)):
                in_front = group in front_groups
                self._front_option.geomgroup[group] = self._option.geomgroup[group] if in_front else 0
                self._option.geomgroup[group] = 0 if in_front else self._option.geomgroup[group]
        self._perturb = mujoco.MjvPerturb()
        self._rect = mujoco.MjrRect(0, 0, render_w, render_h)
        self._rgb = np.empty((render_h, render_w, 3), dtype=np.uint8)
        self._filtered = np.empty((render_h, render_w, 3), dtype=np.uint8)
        self._cameras: dict[str, mujoco.MjvCamera] = {}
        self._category = mujoco.mjtCatBit.mjCAT_ALL.value

    def _camera(self, name: str) -> mujoco.MjvCamera:
        camera = self._cameras.get(name)
        if camera is None:
            camera_id = mujoco.mj_name2id(self._model, mujoco.mjtObj.mjOBJ_CAMERA.value, name)
            if camera_id < 0:
                raise ValueError(f"the model has no camera named {name!r}")
            camera = mujoco.MjvCamera()
            camera.type = mujoco.mjtCamera.mjCAMERA_FIXED.value
            camera.fixedcamid = camera_id
            self._cameras[name] = camera
        return camera

    def rgb(self, data: mujoco.MjData, camera: str) -> np.ndarray:
        """(H, W, 3) uint8 image of a named camera (the shared buffer; see the class note)."""
        self.start(data, camera)
        return self.finish()

    def start(self, data: mujoco.MjData, camera: str) -> None:
        """Begin a frame of `camera` from the state in `data` and return at once; `finish()` gives its pixels.

        The draw calls are flushed, so the GL driver's threads (llvmpipe) rasterise while the caller goes on with
        other work: the env computes the reward and the simtrace row in that time.
        """
        if self._context is None:
            raise RuntimeError("the camera renderer is closed")
        self._gl.make_current()
        if self._front_option is None:
            mujoco.mjv_updateScene(
                self._model, data, self._option, None, self._camera(camera), self._category, self._scene
            )
        else:
            mujoco.mjv_updateScene(
                self._model, data, self._front_option, None, self._camera(camera), self._category, self._scene
            )
            mujoco.mjv_addGeoms(self._model, data, self._option, self._perturb, self._category, self._scene)
        mujoco.mjr_render(self._rect, self._scene, self._context)
        GL.glFlush()

    def finish(self) -> np.ndarray:
        """(H, W, 3) uint8 pixels of the frame begun by `start()` (waits for the driver; the shared buffer)."""
        self._gl.make_current()
        mujoco.mjr_readPixels(self._rgb, None, self._rect, self._context)
        image = self._rgb[::-1]  # OpenGL rows start at the bottom
        if self._resize_to is not None:
            return np.asarray(
                Image.fromarray(np.ascontiguousarray(image)).resize(self._resize_to, resample=Image.BILINEAR)
            )
        if not self._filter_frame:
            return image
        cv2.sepFilter2D(image, -1, RESIZE_KERNEL, RESIZE_KERNEL, dst=self._filtered, borderType=cv2.BORDER_REPLICATE)
        return self._filtered

    def close(self) -> None:
        """Free the GL context and everything drawn with it (idempotent)."""
        self._context = None
        self._gl = None
        self._release()
