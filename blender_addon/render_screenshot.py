"""Render docs/blender_cabinet.png headless: the shipped cabinet sample imported with the
add-on (installed from its built zip), every joint at rest, then one door opened through the
panel's slider.

    .venv-blender/bin/python blender_addon/render_screenshot.py [--out docs/blender_cabinet.png]

Workbench needs an OpenGL context, which a headless machine without a GPU lacks, so this
renders with Cycles on the CPU (a few samples, denoised).
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import shutil
import sys
import tempfile
from pathlib import Path

ADDON = Path(__file__).resolve().parent
REPO = ADDON.parent
SAMPLE = REPO / "pipeline" / "samples" / "cabinet" / "object.json"
MODULE = "bl_ext.user_default.real2code"


def _build_zip(out: Path) -> Path:
    spec = importlib.util.spec_from_file_location("real2code_addon_build", ADDON / "build.py")
    build = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(build)
    return build.build(out)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=REPO / "docs" / "blender_cabinet.png")
    p.add_argument("--door", default="door_4_hinge", help="the joint the slider opens")
    p.add_argument("--angle", type=float, default=80.0, help="degrees")
    p.add_argument("--samples", type=int, default=24)
    args = p.parse_args()
    work = Path(tempfile.mkdtemp(prefix="real2code-screenshot-"))
    os.environ["BLENDER_USER_RESOURCES"] = str(work / "user")
    zip_path = _build_zip(work)
    sys.path[:] = [s for s in sys.path if Path(s or ".").resolve() != REPO]

    import bpy
    from mathutils import Vector

    bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo="user_default",
                                             enable_on_install=True)
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    assert bpy.ops.import_scene.real2code(filepath=str(SAMPLE)) == {"FINISHED"}
    root = bpy.context.view_layer.objects.active
    panel = sys.modules[f"{MODULE}.panel"]
    sliders = panel.joint_sliders(root)
    for je, _, label in sliders:
        panel.set_joint_value(je, math.radians(args.angle) if label == args.door else 0.0)
    bpy.context.view_layer.update()

    scene = bpy.context.scene
    meshes = [o for o in scene.objects if o.type == "MESH" and o.visible_get()]
    corners = [o.matrix_world @ Vector(c) for o in meshes for c in o.bound_box]
    lo = Vector([min(c[i] for c in corners) for i in range(3)])
    hi = Vector([max(c[i] for c in corners) for i in range(3)])
    center, size = (lo + hi) / 2, (hi - lo).length

    floor_data = bpy.data.meshes.new("floor")
    floor_data.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    floor = bpy.data.objects.new("floor", floor_data)
    floor.scale = (3 * size, 3 * size, 1)
    floor.location.z = lo.z
    scene.collection.objects.link(floor)

    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    cam.location = center + Vector((1.35, -0.95, 0.75)) * size  # front (+x) right, above
    cam.rotation_euler = (center - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 40
    scene.collection.objects.link(cam)
    scene.camera = cam
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (math.radians(40), math.radians(10), math.radians(60))
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("world")
    world.color = (0.8, 0.82, 0.85)
    scene.world = world
    if world.node_tree is None:  # Blender < 5.0
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.8, 0.82, 0.85, 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.9

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = args.samples
    scene.cycles.use_denoising = True
    scene.render.resolution_x, scene.render.resolution_y = 960, 720
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = str(work / "render.png")
    bpy.ops.render.render(write_still=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    staged = args.out.with_name(f".{args.out.name}.tmp")
    shutil.copyfile(work / "render.png", staged)
    os.replace(staged, args.out)  # never a half-written picture in docs/
    print(f"{args.out}: {args.door} at {args.angle:.0f} degrees through the panel slider")


if __name__ == "__main__":
    main()
