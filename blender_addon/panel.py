"""The sidebar panel (View3D > Sidebar > Real2Code): a slider per joint that poses the parts,
export, and the last check's result.

A slider is a property of every object (``real2code_angle``, ``real2code_distance``) that
reads and writes a joint Empty's motion channel, held inside the joint's range as its custom
properties give it now: edit a limit and the slider stops at the new one."""

from __future__ import annotations

import math

import bpy
from bpy.props import EnumProperty, FloatProperty

from . import rig_props as rp
from .from_blender import find_rig, rig_joints

CHECK_LINES_SHOWN = 6


SLIDER_ANGLE, SLIDER_DISTANCE = "real2code_angle", "real2code_distance"


def _slider_get(ob) -> float:
    return rp.joint_value(ob) if rp.motion_channel(ob) is not None else 0.0


def _slider_set(ob, value: float) -> None:
    if rp.motion_channel(ob) is not None:
        rp.set_joint_value(ob, value)


SLIDER_PROPERTIES = {
    SLIDER_ANGLE: FloatProperty(name="Joint angle", subtype="ANGLE", unit="ROTATION",
                                soft_min=-math.pi, soft_max=math.pi, get=_slider_get,
                                set=_slider_set, description="The joint's angle, held in its "
                                "range"),
    SLIDER_DISTANCE: FloatProperty(name="Joint distance", subtype="DISTANCE", unit="LENGTH",
                                   soft_min=-1.0, soft_max=1.0, get=_slider_get,
                                   set=_slider_set, description="The joint's travel, held in "
                                   "its range"),
}


def joint_sliders(root: bpy.types.Object) -> list[tuple[bpy.types.Object, str, str]]:
    """(object, property, label) of every slider the panel draws: one per movable joint."""
    out = []
    for je in rig_joints(root):
        channel = rp.motion_channel(je)
        if channel is not None:
            prop = SLIDER_ANGLE if channel[0] == "rotation_euler" else SLIDER_DISTANCE
            out.append((je, prop, je.get(rp.NAME, je.name)))
    return out


def set_joint_value(je: bpy.types.Object, value: float) -> None:
    """Set a joint the way the slider does: held in its range now."""
    rp.set_joint_value(je, value)


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
            # (the rest pose 0 is held inside the range when the range excludes it)
            value = float(je.get(rp.STATE, 0.0)) if self.pose == "OBSERVED" else 0.0
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


def register_properties() -> None:
    for name, prop in SLIDER_PROPERTIES.items():
        setattr(bpy.types.Object, name, prop)


def unregister_properties() -> None:
    for name in SLIDER_PROPERTIES:
        delattr(bpy.types.Object, name)
