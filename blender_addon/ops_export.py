"""File > Export > Articulated Object: the rig back to the model, out to every format, then
``real2code check`` on the files, its result shown in the panel."""

from __future__ import annotations

import traceback
import warnings
from pathlib import Path

import bpy
from bpy.props import BoolProperty, EnumProperty, StringProperty

from real2code_export.formats import FORMATS

from . import rig_props as rp
from .from_blender import compare_with_viewport, find_rig, read_rig, read_rig_objects

# every format the registry knows (a format's label and description are the registry's)
FORMAT_ITEMS = tuple((f.name, f.label, f.description) for f in FORMATS.values())
EXPORTED = ", ".join(f.label for f in FORMATS.values() if f.exported)  # MJCF, URDF, USD, glTF


def export_rig(root: bpy.types.Object, out: Path, formats, view_layer=None) -> dict[str, Path]:
    """Write the model the rig shows into ``out`` in ``formats`` (all files or none). With a
    view layer, the model is first posed beside the viewport (``compare_with_viewport``) and
    nothing is written where they part."""
    from real2code_export.errors import ModelError
    from real2code_export.formats import export

    if "usd" in formats:
        from .usd_support import ensure_pxr

        ensure_pxr()
    if view_layer is None:
        return export(read_rig(root), out, list(formats))
    view_layer.update()
    reading = read_rig_objects(root, view_layer.depsgraph)
    mismatches = compare_with_viewport(reading, view_layer)
    if mismatches:
        raise ModelError(f"rig {root.name!r}", "the exported model would not move as Blender "
                         "shows it: " + "; ".join(mismatches[:3]))
    return export(reading.model, out, list(formats))


def check_exported(files: list[Path], executable: str, configurations: int):
    from .check_run import find_executable, run_full, run_inside

    found = find_executable(executable)
    if found is not None:
        return run_full(found, files, configurations)
    return run_inside(files, configurations)


class EXPORT_SCENE_OT_real2code(bpy.types.Operator):
    bl_idname = "export_scene.real2code"
    bl_description = f"Export the active articulated object ({EXPORTED}), then check the files"
    bl_label = "Export Articulated Object"
    bl_options = {"REGISTER"}

    directory: StringProperty(name="Folder", subtype="DIR_PATH",
                              description="Folder the files are written into")
    filter_folder: BoolProperty(default=True, options={"HIDDEN"})
    formats: EnumProperty(name="Formats", items=FORMAT_ITEMS, options={"ENUM_FLAG"},
                          default={item[0] for item in FORMAT_ITEMS})
    run_check: BoolProperty(name="Check", default=True,
                            description="Load the files in their own tools and compare poses")

    @classmethod
    def poll(cls, context):
        return find_rig(context.active_object) is not None

    def invoke(self, context, event):
        if self.directory:
            return self.execute(context)
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        from real2code_export.errors import Real2CodeError, Real2CodeWarning

        from . import preferences

        root = find_rig(context.active_object)
        if not self.directory:
            self.report({"ERROR"}, "Export: choose a folder")
            return {"CANCELLED"}
        out = Path(bpy.path.abspath(self.directory))
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", Real2CodeWarning)
                written = export_rig(root, out, sorted(self.formats), context.view_layer)
        except Real2CodeError as e:
            self.report({"ERROR"}, f"Export failed, nothing written: {e}")
            return {"CANCELLED"}
        except Exception as e:
            traceback.print_exc()
            self.report({"ERROR"}, f"Export failed, nothing written: {type(e).__name__}: {e}")
            return {"CANCELLED"}
        for note in dict.fromkeys(str(w.message) for w in caught
                                  if issubclass(w.category, Real2CodeWarning)):
            self.report({"WARNING"}, note)
        self.report({"INFO"}, f"Wrote {len(written)} files to {out}, matching the viewport")
        if not self.run_check:
            return {"FINISHED"}
        prefs = preferences.get(context)
        try:
            outcome = check_exported(list(written.values()), prefs.real2code_executable,
                                     prefs.check_configurations)
        except Real2CodeError as e:
            self.report({"WARNING"}, f"Check could not run: {e}")
            return {"FINISHED"}
        root[rp.CHECK] = outcome.to_json()
        print(outcome.table)
        self.report({"INFO"} if outcome.ok else {"WARNING"}, outcome.summary())
        for line in outcome.mismatches[:5]:
            self.report({"WARNING"}, line)
        return {"FINISHED"}


def menu_export(self, context):
    self.layout.operator(EXPORT_SCENE_OT_real2code.bl_idname,
                         text=f"Articulated Object ({EXPORTED})")


CLASSES = (EXPORT_SCENE_OT_real2code,)
MENUS = ((bpy.types.TOPBAR_MT_file_export, menu_export),)
