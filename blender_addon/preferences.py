"""The add-on's preferences: where the full ``real2code check`` lives."""

from __future__ import annotations

import bpy
from bpy.props import IntProperty, StringProperty


class Real2CodePreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    real2code_executable: StringProperty(
        name="real2code command",
        description="The real2code command of the project's own environment (e.g. "
        ".venv/bin/real2code): runs the full check (MuJoCo, Pinocchio, UsdPhysics, the Khronos "
        "glTF validator). Empty: real2code on PATH, else a partial check inside Blender",
        subtype="FILE_PATH",
        default="",
    )
    check_configurations: IntProperty(
        name="Check configurations",
        description="Random joint configurations the check poses every file at",
        default=100, min=1, max=10000,
    )

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "real2code_executable")
        layout.prop(self, "check_configurations")


def get(context) -> Real2CodePreferences:
    return context.preferences.addons[__package__].preferences
