"""File > Import > Articulated Object, and drag-and-drop of the same files."""

from __future__ import annotations

import traceback
import warnings
from pathlib import Path

import bpy
from bpy.props import CollectionProperty, StringProperty
from bpy_extras.io_utils import ImportHelper, poll_file_object_drop

from real2code_export.formats import FORMATS, suffixes

EXTENSIONS = suffixes()  # every format the project reads (the registry's list)
# the menu entry names each format by its first suffix: (.json, .xml, .urdf, .usda, .glb)
MENU_TEXT = f"Articulated Object ({', '.join(f.suffixes[0] for f in FORMATS.values())})"
MAX_WARNINGS_SHOWN = 5


def load_model(path: Path):
    """The model in ``path`` (any format the project reads) and the repair warnings it gave."""
    from real2code_export.errors import Real2CodeWarning
    from real2code_export.formats import load

    if path.suffix.lower() in FORMATS["usd"].suffixes:
        from .usd_support import ensure_pxr

        ensure_pxr()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", Real2CodeWarning)
        obj = load(path)
    notes = list(dict.fromkeys(str(w.message) for w in caught
                               if issubclass(w.category, Real2CodeWarning)))
    return obj, notes


def import_file(context, path: Path):
    """Load ``path`` and build its rig; the scene is untouched when this raises."""
    from .to_blender import build_rig

    obj, notes = load_model(path)
    root = build_rig(obj, context.scene, source=str(path))
    context.view_layer.update()
    return root, notes


class IMPORT_SCENE_OT_real2code(bpy.types.Operator, ImportHelper):
    bl_idname = "import_scene.real2code"
    bl_description = (f"Import an articulated object "
                      f"({', '.join(f.label for f in FORMATS.values())}) as a posable rig")
    bl_label = "Import Articulated Object"
    bl_options = {"REGISTER", "UNDO", "PRESET"}

    filter_glob: StringProperty(default=";".join(f"*{e}" for e in EXTENSIONS),
                                options={"HIDDEN"})
    directory: StringProperty(subtype="DIR_PATH", options={"SKIP_SAVE", "HIDDEN"})
    files: CollectionProperty(type=bpy.types.OperatorFileListElement,
                              options={"SKIP_SAVE", "HIDDEN"})

    def invoke(self, context, event):
        if self.properties.is_property_set("filepath"):  # dropped on the viewport
            return self.execute(context)
        return super().invoke(context, event)

    def paths(self) -> list[Path]:
        if self.files and self.directory:
            return [Path(self.directory) / f.name for f in self.files if f.name]
        return [Path(self.filepath)]

    def execute(self, context):
        from real2code_export.errors import Real2CodeError

        from .to_blender import remove_rig

        imported = []
        for path in self.paths():
            try:
                root, notes = import_file(context, path)
            except Exception as e:
                for done in imported:  # all files or none
                    remove_rig(done)
                if isinstance(e, Real2CodeError):
                    message = str(e)
                else:  # a bug or a tool's own exception: still say what and where
                    traceback.print_exc()
                    message = f"{path}: {type(e).__name__}: {e}"
                self.report({"ERROR"}, f"Import failed, scene unchanged: {message}")
                return {"CANCELLED"}
            for note in notes[:MAX_WARNINGS_SHOWN]:
                self.report({"WARNING"}, note)
            if len(notes) > MAX_WARNINGS_SHOWN:
                self.report({"WARNING"}, f"{len(notes) - MAX_WARNINGS_SHOWN} more warnings "
                            "(see the system console)")
                for note in notes[MAX_WARNINGS_SHOWN:]:
                    print(f"real2code: warning: {note}")
            imported.append(root)
        for ob in context.view_layer.objects:
            ob.select_set(False)
        for root in imported:
            root.select_set(True)
        context.view_layer.objects.active = imported[-1]
        self.report({"INFO"}, f"Imported {', '.join(r.name for r in imported)}")
        return {"FINISHED"}


class IMPORT_SCENE_FH_real2code(bpy.types.FileHandler):
    bl_idname = "IMPORT_SCENE_FH_real2code"
    bl_label = "Articulated Object (real2code)"
    bl_import_operator = IMPORT_SCENE_OT_real2code.bl_idname
    bl_file_extensions = ";".join(EXTENSIONS)

    @classmethod
    def poll_drop(cls, context):
        return poll_file_object_drop(context)


def menu_import(self, context):
    self.layout.operator(IMPORT_SCENE_OT_real2code.bl_idname, text=MENU_TEXT)


CLASSES = (IMPORT_SCENE_OT_real2code, IMPORT_SCENE_FH_real2code)
MENUS = ((bpy.types.TOPBAR_MT_file_import, menu_import),)
