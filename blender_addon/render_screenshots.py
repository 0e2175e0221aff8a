"""Render the Blender pictures in docs/ headless, each from what a user does in Blender:

    .venv-blender/bin/python blender_addon/render_screenshots.py [--only SHOT ...] [--samples N]

Shots (``docs/<shot>.png``):

- ``blender_cabinet``: the shipped cabinet sample imported with the add-on (installed from its
  built zip), a door opened through the panel's slider.
- ``blender_artist``: what an artist does to the rig, then exports: the rig scaled x2, one
  door scaled x1.5, a handle parented to the drawer, a door turned by its Empty's own Z
  rotation (the rotate gizmo's channel), the drawer pulled out. Left: the scene as Blender
  shows it. Right: the exported object.json imported again into an empty scene, seen by
  the same camera. The largest distance between a part's vertices in the two is printed.
- ``blender_gltf_importer``: our .glb in Blender's own glTF importer, no add-on: the first
  frame and a quarter through the animation that plays every joint together.
- ``blender_usd_importer``: our USD in Blender's own USD importer, no add-on, each mesh
  object labelled with the name Blender gave it.

The exports come from the main venv's ``real2code export`` (``.venv/bin/real2code``).
Workbench needs an OpenGL context, which a headless machine without a GPU lacks, so this
renders with Cycles on the CPU (a few samples, denoised).
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ADDON = Path(__file__).resolve().parent
REPO = ADDON.parent
DOCS = REPO / "docs"
SAMPLE = REPO / "pipeline" / "samples" / "cabinet" / "object.json"
REAL2CODE = REPO / ".venv" / "bin" / "real2code"
MODULE = "bl_ext.user_default.real2code"
PANEL = (640, 480)  # pixels of one picture in a side-by-side pair


def _build_zip(out: Path) -> Path:
    spec = importlib.util.spec_from_file_location("real2code_addon_build", ADDON / "build.py")
    build = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(build)
    return build.build(out)


def _addon(name: str):
    return sys.modules[f"{MODULE}.{name}"]


# -- staging --------------------------------------------------------------------------------
def _empty_scene():
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    return bpy.context.scene


def _visible_meshes(scene) -> list:
    return [o for o in scene.objects if o.type == "MESH" and o.visible_get()]


def _frame(scene):
    """(centre, size) of what the scene's visible meshes cover."""
    from mathutils import Vector

    corners = [o.matrix_world @ Vector(c) for o in _visible_meshes(scene) for c in o.bound_box]
    lo = Vector([min(c[i] for c in corners) for i in range(3)])
    hi = Vector([max(c[i] for c in corners) for i in range(3)])
    return (lo + hi) / 2, (hi - lo).length, lo.z


def _stage(scene, frame, direction=(1.35, -0.95, 0.75)) -> None:
    """Floor, camera, sun and sky around ``frame``; the camera looks from ``direction``
    (object frame: +x is the front of our furniture), scaled by the frame's size."""
    import bpy
    from mathutils import Vector

    center, size, floor_z = frame
    floor_data = bpy.data.meshes.new("floor")
    floor_data.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    floor = bpy.data.objects.new("floor", floor_data)
    floor.scale = (3 * size, 3 * size, 1)
    floor.location = (center.x, center.y, floor_z)
    scene.collection.objects.link(floor)

    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    cam.location = center + Vector(direction) * size
    cam.rotation_euler = (center - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 40
    scene.collection.objects.link(cam)
    scene.camera = cam
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (math.radians(40), math.radians(10), math.radians(60))
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("world")
    scene.world = world
    if world.node_tree is None:  # Blender < 5.0
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.8, 0.82, 0.85, 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.9


def _render(scene, path: Path, samples: int, size=PANEL) -> Path:
    import bpy

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = True
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return path


def _side_by_side(pictures: list[tuple[Path, str]], out: Path) -> None:
    """The pictures in a row, each captioned, written to ``out`` whole or not at all."""
    from PIL import Image, ImageDraw, ImageFont

    images = [Image.open(p).convert("RGB") for p, _ in pictures]
    band, font = 34, ImageFont.load_default(size=17)
    w, h = sum(i.width for i in images), max(i.height for i in images) + band
    sheet = Image.new("RGB", (w, h), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    x = 0
    for image, (_, caption) in zip(images, pictures, strict=True):
        sheet.paste(image, (x, band))
        draw.text((x + 10, 8), caption, fill=(0, 0, 0), font=font)
        x += image.width
    _publish(sheet, out)


def _publish(image, out: Path) -> None:
    out.parent.mkdir(parents=True, exist_ok=True)
    staged = out.with_name(f".{out.name}.tmp")
    image.save(staged, format="PNG")
    os.replace(staged, out)  # never a half-written picture in docs/


def _export(source: Path, fmt: str, out: Path) -> Path:
    """The main venv's ``real2code export`` (what a user runs) to one format: the file it
    wrote, as it prints it (``<format> <path>``; the registry names the file, not this script)."""
    if not REAL2CODE.is_file():
        sys.exit(f"{REAL2CODE} is missing: run scripts/setup.sh first")
    done = subprocess.run([str(REAL2CODE), "export", str(source), "--to", fmt, "--out",
                           str(out)], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        sys.exit(f"real2code export {source} failed:\n{done.stderr}")
    written = dict(line.split(maxsplit=1) for line in done.stdout.splitlines() if line.strip())
    return Path(written[fmt])


# -- shots ----------------------------------------------------------------------------------
def shot_cabinet(work: Path, samples: int) -> None:
    import bpy

    scene = _empty_scene()
    assert bpy.ops.import_scene.real2code(filepath=str(SAMPLE)) == {"FINISHED"}
    root = bpy.context.view_layer.objects.active
    panel = _addon("panel")
    for je, _, label in panel.joint_sliders(root):
        panel.set_joint_value(je, math.radians(80.0) if label == "door_4_hinge" else 0.0)
    bpy.context.view_layer.update()
    _stage(scene, _frame(scene))
    _publish(_open(_render(scene, work / "cabinet.png", samples, (960, 720))),
             DOCS / "blender_cabinet.png")


def _open(path: Path):
    from PIL import Image

    return Image.open(path).convert("RGB")


def _rig(root, role: str) -> dict:
    rp = _addon("rig_props")
    return {o[rp.NAME]: o for o in root.users_collection[0].all_objects if o.get(rp.ROLE) == role}


def _part_vertices(scene, names) -> dict:
    """part name -> its visible mesh's vertices in world coordinates."""
    import bpy
    import numpy as np

    rp = _addon("rig_props")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    out = {}
    for ob in scene.objects:
        if ob.type != "MESH" or ob.get(rp.ROLE) != rp.ROLE_PART or ob.get(rp.NAME) not in names:
            continue
        evaluated = ob.evaluated_get(depsgraph)
        data = evaluated.to_mesh()
        co = np.array([v.co for v in data.vertices], dtype=np.float64)
        evaluated.to_mesh_clear()
        world = np.array(evaluated.matrix_world, dtype=np.float64)
        out[ob[rp.NAME]] = co @ world[:3, :3].T + world[:3, 3]
    return out


def shot_artist(work: Path, samples: int) -> None:
    import bmesh
    import bpy
    import numpy as np

    rp = _addon("rig_props")
    scene = _empty_scene()
    assert bpy.ops.import_scene.real2code(filepath=str(SAMPLE)) == {"FINISHED"}
    root = bpy.context.view_layer.objects.active
    parts, joints = _rig(root, rp.ROLE_PART), _rig(root, rp.ROLE_JOINT)
    root.scale = (2.0, 2.0, 2.0)  # the rig x2
    parts["door_0"].scale = (1.5, 1.5, 1.5)  # one part x1.5
    joints["door_4_hinge"].rotation_euler.z = math.radians(70)  # the rotate gizmo's channel
    rp.set_joint_value(joints["drawer_1_slide"], 0.15)
    bpy.context.view_layer.update()
    drawer = parts["drawer_1"]
    data = bpy.data.meshes.new("handle")
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0)
    bm.to_mesh(data)
    bm.free()
    handle = bpy.data.objects.new("handle", data)
    handle.scale = (0.04, 0.3, 0.05)  # a bar across the drawer's front (+x)
    front = max((drawer.matrix_world @ v.co for v in drawer.data.vertices), key=lambda p: p.x)
    handle.location = (front.x + 0.04, drawer.matrix_world.translation.y,
                       drawer.matrix_world.translation.z)
    material = bpy.data.materials.new("handle")
    red = (0.75, 0.1, 0.08, 1.0)
    material.diffuse_color = red
    if material.node_tree is None:  # Blender < 5.0
        material.use_nodes = True
    material.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = red
    data.materials.append(material)
    scene.collection.objects.link(handle)
    bpy.context.view_layer.update()
    handle.parent = drawer  # as Ctrl+P does: it stays where it is
    handle.matrix_parent_inverse = drawer.matrix_world.inverted()
    bpy.context.view_layer.update()

    frame = _frame(scene)
    exported = work / "artist"
    _addon("ops_export").export_rig(root, exported, ["json"], bpy.context.view_layer)
    reading = _addon("from_blender").read_rig_objects(root, bpy.context.evaluated_depsgraph_get())
    pose = _addon("from_blender").rig_configuration(reading)  # model units, as shown
    names = list(parts)
    shown = _part_vertices(scene, names)
    _stage(scene, frame)
    left = _render(scene, work / "artist_blender.png", samples)

    scene = _empty_scene()
    assert bpy.ops.import_scene.real2code(filepath=str(exported / "object.json")) == {"FINISHED"}
    again = _rig(bpy.context.view_layer.objects.active, rp.ROLE_JOINT)
    for name, value in pose.items():  # the file's rest is the sample's; pose it as shown
        rp.set_joint_value(again[name], value)
    bpy.context.view_layer.update()
    back = _part_vertices(scene, names)
    gap = max(float(np.linalg.norm(shown[n] - back[n][: len(shown[n])], axis=1).max())
              for n in shown)
    _stage(scene, frame)
    right = _render(scene, work / "artist_export.png", samples)
    _side_by_side([(left, "Blender: rig x2, door_0 x1.5, a handle parented, door_4 by R"),
                   (right, "The export, imported again (one colour a part)")],
                  DOCS / "blender_artist.png")
    print(f"blender_artist: largest vertex distance, Blender vs the export read back: "
          f"{gap * 1000:.4f} mm")


def shot_gltf_importer(work: Path, samples: int) -> None:
    import bpy

    glb = _export(SAMPLE, "gltf", work / "gltf")
    scene = _empty_scene()
    assert bpy.ops.import_scene.gltf(filepath=str(glb)) == {"FINISHED"}
    orphans = bpy.data.collections.get("Orphan Nodes")
    if orphans is not None:  # the KHR_physics collider meshes, which glTF keeps out of the scene
        for ob in orphans.all_objects:
            ob.hide_render = True
            ob.hide_set(True)
    action = next(a for a in bpy.data.actions if a.name.endswith("all joints"))
    start, end = (int(v) for v in action.frame_range)
    pictures = []
    for frame, label in ((start, "frame"), ((start + end) // 4, "frame")):
        scene.frame_set(frame)
        bpy.context.view_layer.update()
        if not pictures:
            _stage(scene, _frame(scene))
        pictures.append((_render(scene, work / f"gltf_{frame}.png", samples),
                         f"Blender's glTF importer, '{action.name}', {label} {frame}"))
    _side_by_side(pictures, DOCS / "blender_gltf_importer.png")
    print(f"blender_gltf_importer: frames {start} and {(start + end) // 4} of {action.name!r}; "
          f"{len(orphans.all_objects) if orphans else 0} collider objects hidden")


def shot_usd_importer(work: Path, samples: int) -> None:
    """The render, each mesh object's name at its projected centre, and beside it the object
    tree the importer made (as the Outliner lists it)."""
    import bpy
    from bpy_extras.object_utils import world_to_camera_view
    from mathutils import Vector
    from PIL import Image, ImageDraw, ImageFont

    usd = _export(SAMPLE, "usd", work / "usd")
    scene = _empty_scene()
    assert bpy.ops.wm.usd_import(filepath=str(usd)) == {"FINISHED"}
    bpy.context.view_layer.update()
    imported = list(scene.objects)
    _stage(scene, _frame(scene))
    size = (960, 720)
    picture = _open(_render(scene, work / "usd.png", samples, size))
    draw, font = ImageDraw.Draw(picture), ImageFont.load_default(size=18)
    for ob in imported:
        if ob.type != "MESH":
            continue
        centre = sum((ob.matrix_world @ Vector(c) for c in ob.bound_box), Vector()) / 8
        u, v, _ = world_to_camera_view(scene, scene.camera, centre)
        x, y = u * size[0], (1.0 - v) * size[1]
        box = draw.textbbox((x, y), ob.name, font=font, anchor="mm")
        draw.rectangle((box[0] - 4, box[1] - 3, box[2] + 4, box[3] + 3), fill=(255, 255, 255))
        draw.text((x, y), ob.name, fill=(0, 0, 0), font=font, anchor="mm")

    lines = ["Outliner, as Blender's USD importer made it:", ""]

    def tree(ob, depth: int) -> None:
        lines.append(f"{'    ' * depth}{ob.name}  ({ob.type.lower()})")
        for child in sorted(ob.children, key=lambda o: o.name):
            tree(child, depth + 1)

    for ob in sorted((o for o in imported if o.parent is None), key=lambda o: o.name):
        tree(ob, 0)
    panel = Image.new("RGB", (440, size[1]), (250, 250, 250))
    ImageDraw.Draw(panel).multiline_text((16, 16), "\n".join(lines), fill=(0, 0, 0),
                                          font=ImageFont.load_default(size=16), spacing=6)
    sheet = Image.new("RGB", (size[0] + panel.width, size[1]), (255, 255, 255))
    sheet.paste(picture, (0, 0))
    sheet.paste(panel, (size[0], 0))
    _publish(sheet, DOCS / "blender_usd_importer.png")
    print("blender_usd_importer: " + ", ".join(
        sorted(o.name for o in imported if o.type == "MESH")))


SHOTS = {"blender_cabinet": shot_cabinet, "blender_artist": shot_artist,
         "blender_gltf_importer": shot_gltf_importer, "blender_usd_importer": shot_usd_importer}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--only", nargs="+", choices=sorted(SHOTS), help="render these shots only")
    p.add_argument("--samples", type=int, default=24)
    args = p.parse_args()
    work = Path(tempfile.mkdtemp(prefix="real2code-screenshots-"))
    os.environ["BLENDER_USER_RESOURCES"] = str(work / "user")
    zip_path = _build_zip(work)
    sys.path[:] = [s for s in sys.path if Path(s or ".").resolve() != REPO]

    import bpy

    bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo="user_default",
                                             enable_on_install=True)
    for name in args.only or SHOTS:
        SHOTS[name](work, args.samples)
        print(f"{DOCS / name}.png written")
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
