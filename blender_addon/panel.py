"""The sidebar panel (View3D > Sidebar > Real2Code): a slider per joint that poses the parts,
export, and the last check's result."""

from __future__ import annotations

import bpy
from bpy.props import EnumProperty

from . import rig_props as rp
from .from_blender import find_rig, rig_joints

CHECK_LINES_SHOWN = 6


def joint_sliders(root: bpy.types.Object) -> list[tuple[bpy.types.Object, str, str]]:
    """(object, property path, label) of every slider the panel draws: one per movable joint,
    the joint Empty's ``real2code_value``."""
    return [(je, f'["{rp.VALUE}"]', je.get(rp.NAME, je.name))
            for je in rig_joints(root) if rp.VALUE in je]


def set_joint_value(je: bpy.types.Object, value: float) -> None:
    """Set a joint the way the slider does (the UI tags the object for re-evaluation; a
    script must do it itself)."""
    je[rp.VALUE] = value
    je.update_tag()


class REAL2CODE_OT_pose(bpy.types.Operator):
    """Put every joint of the active articulated object at rest (q = 0) or at the observed state"""

    bl_idname = "real2code.pose"
    bl_label = "Pose Articulated Object"
    bl_options = {"REGISTER", "UNDO"}

    pose: EnumProperty(items=(("REST", "Rest", "Every joint at 0 (within its range)"),
                              ("OBSERVED", "Observed", "Every joint at its observed state")))

    @classmethod
    def poll(cls, context):
        return find_rig(context.active_object) is not None

    def execute(self, context):
        for je, _, _ in joint_sliders(find_rig(context.active_object)):
            if self.pose == "OBSERVED":
                value = float(je.get(rp.STATE, 0.0))
            else:
                value = min(max(0.0, je.get(rp.LOWER, 0.0)), je.get(rp.UPPER, 0.0)) \
                    if rp.LOWER in je else 0.0
            set_joint_value(je, value)
        return {"FINISHED"}


class VIEW3D_PT_real2code(bpy.types.Panel):
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Real2Code"
    bl_label = "Articulated Object"

    @classmethod
    def poll(cls, context):
        return find_rig(context.active_object) is not None

    def draw(self, context):
        layout = self.layout
        root = find_rig(context.active_object)
        layout.label(text=root.get(rp.NAME, root.name), icon="OUTLINER_OB_ARMATURE")
        col = layout.column(align=True)
        sliders = joint_sliders(root)
        for ob, path, label in sliders:
            col.prop(ob, path, text=label, slider=True)
        if not sliders:
            col.label(text="No movable joints")
        row = layout.row(align=True)
        row.operator(REAL2CODE_OT_pose.bl_idname, text="Rest").pose = "REST"
        row.operator(REAL2CODE_OT_pose.bl_idname, text="Observed").pose = "OBSERVED"
        layout.operator("export_scene.real2code", text="Export and Check", icon="EXPORT")
        _draw_check(layout, root)


def _draw_check(layout, root) -> None:
    from .check_run import CheckOutcome

    text = root.get(rp.CHECK)
    if not isinstance(text, str):
        return
    outcome = CheckOutcome.from_json(text)
    box = layout.box()
    box.label(text=outcome.summary(), icon="CHECKMARK" if outcome.ok else "ERROR")
    for probe in outcome.probes:
        err = probe["max_position_error"]
        detail = "reference" if probe["reference"] else \
            f"{err:.1e} m" if err is not None else "no pose"
        box.label(text=f"{probe['name']}: {detail}",
                  icon="CHECKMARK" if probe["ok"] else "CANCEL")
    for line in outcome.mismatches[:CHECK_LINES_SHOWN]:
        box.label(text=line, icon="ERROR")
    for line in outcome.skipped:
        box.label(text=f"skipped: {line}", icon="INFO")


CLASSES = (REAL2CODE_OT_pose, VIEW3D_PT_real2code)
