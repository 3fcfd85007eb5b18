"""The one place that imports :mod:`mujoco` (lazily), with an actionable error if it is missing."""

from __future__ import annotations

import os
import sys

INSTALL_HINT = "pip install 'cepam-gym[mujoco]'"


def require_mujoco():
    """Return the :mod:`mujoco` module, importing it now.

    Picks the headless ``egl`` back-end when ``MUJOCO_GL`` is unset and no display is available
    (set ``MUJOCO_GL=osmesa`` yourself for software rendering without EGL).
    """
    if (
        "mujoco" not in sys.modules
        and "MUJOCO_GL" not in os.environ
        and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
        and sys.platform.startswith("linux")
    ):
        os.environ["MUJOCO_GL"] = "egl"
    try:
        import mujoco
    except ImportError as e:
        raise ImportError(
            f"this feature needs MuJoCo, which is not installed ({e}); install the extra with {INSTALL_HINT}"
        ) from e
    return mujoco


def make_renderer(mujoco, model, height: int, width: int):
    """``mujoco.Renderer`` with a hint on the OpenGL back-end when it cannot start."""
    try:
        return mujoco.Renderer(model, height=height, width=width)
    except Exception as e:  # the back-ends raise assorted errors (RuntimeError, AttributeError...)
        gl = os.environ.get("MUJOCO_GL", "<unset>")
        raise RuntimeError(
            f"MuJoCo could not open an OpenGL context for offscreen rendering (MUJOCO_GL={gl}): {e}. "
            "Headless: MUJOCO_GL=egl (GPU or Mesa EGL), or MUJOCO_GL=osmesa after installing "
            "libosmesa6; with a display: MUJOCO_GL=glfw"
        ) from e


_SCENE = """  <visual>
    <global offwidth="{w}" offheight="{h}"/>
    <quality shadowsize="2048"/>
    <headlight ambient="0.45 0.45 0.45" diffuse="0.55 0.55 0.55" specular="0.1 0.1 0.1"/>
  </visual>
  <asset>
    <texture name="grid" type="2d" builtin="checker" rgb1="0.93 0.93 0.93" rgb2="0.86 0.86 0.88"
             width="256" height="256"/>
    <material name="grid" texture="grid" texrepeat="8 8"/>
    <texture name="sky" type="skybox" builtin="gradient" rgb1="1 1 1" rgb2="0.8 0.84 0.9" width="256" height="256"/>
    <material name="metal" rgba="0.55 0.57 0.6 1" specular="0.6" shininess="0.6"/>
    <material name="dark" rgba="0.18 0.18 0.2 1" specular="0.4"/>
"""


def scene_header(width: int, height: int) -> str:
    """The MJCF lines the rig and the joint share: offscreen size, lighting, floor and metal
    materials. It opens an ``<asset>`` block that the caller's model closes."""
    return _SCENE.format(w=width, h=height)
