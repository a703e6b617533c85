"""Export a keyframed Blender scene to USD, for a manual check of phongscene's time support.

Usage:  /work/scratch/blender/venv/bin/python build_animated.py OUT.usda

Frames 1..24: a sphere keyframed from x = -3 to x = 3 (and a quarter turn about Z), a point light
whose power is keyframed 500 -> 1500 W, and a camera keyframed from y = -10 to y = -12, looking
along +Y. Exported with bpy.ops.wm.usd_export(export_animation=True) in the TRS xform-op mode of
build_scenes.py (translate/rotateXYZ/scale with timeSamples). No render: Cycles is not needed.
"""

import math
import sys

import bpy
from build_scenes import USD_EXPORT_OPTS, add_camera, add_light, add_plane, add_sphere, principled, reset


def main(out):
    scene = reset()
    scene.frame_start, scene.frame_end = 1, 24
    scene.render.fps = 24
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    white = principled("White", base=(0.8, 0.8, 0.8), roughness=0.5)
    red = principled("Red", base=(0.8, 0.1, 0.1), roughness=0.4)
    add_plane("Ground", 20, white, z=0.0)
    ball = add_sphere("Ball", 1.0, (-3, 0, 1), red, segments=32, rings=16)
    cam = add_camera(scene, (0, -10, 2), rot=(math.radians(90), 0, 0), lens=35.0)
    light = add_light(scene, "Key", "POINT", (-2, -4, 6), 500.0)
    for frame, x, turn, power, y in ((1, -3.0, 0.0, 500.0, -10.0), (24, 3.0, 90.0, 1500.0, -12.0)):
        scene.frame_set(frame)
        ball.location.x = x
        ball.rotation_euler.z = math.radians(turn)
        ball.keyframe_insert("location", index=0)
        ball.keyframe_insert("rotation_euler", index=2)
        light.data.energy = power
        light.data.keyframe_insert("energy")
        cam.location.y = y
        cam.keyframe_insert("location", index=1)
    # Blender interpolates keyframes with Bezier curves; the exporter writes a sample per frame, so
    # USD's linear interpolation between integer frames reproduces Blender at every frame.
    options = dict(USD_EXPORT_OPTS, export_animation=True)
    print("usd_export ->", bpy.ops.wm.usd_export(filepath=out, check_existing=False, **options))


if __name__ == "__main__":
    main(sys.argv[-1])
