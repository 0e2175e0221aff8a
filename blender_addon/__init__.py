"""Real2Code articulated objects in Blender: import object.json, URDF, MJCF, glTF and USD files
of the real2code_export project as posable rigs, and export them back through the same
writers, checked by ``real2code check``. See docs/blender.md."""

from __future__ import annotations

import bpy

from . import ops_export, ops_import, panel, preferences, usd_support

CLASSES = (preferences.Real2CodePreferences, *ops_import.CLASSES, *ops_export.CLASSES,
           *panel.CLASSES)
MENUS = (*ops_import.MENUS, *ops_export.MENUS)


def register():
    # Before anything (Blender's own USD import/export included) builds USD's schema
    # registry, which never takes plug-ins registered later: see usd_support.
    usd_support.ensure_pxr()
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    panel.register_properties()
    for menu, draw in MENUS:
        menu.append(draw)


def unregister():
    for menu, draw in reversed(MENUS):
        menu.remove(draw)
    panel.unregister_properties()
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
