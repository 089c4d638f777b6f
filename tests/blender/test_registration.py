"""The add-on registers and unregisters cleanly and Caustic shows up as a render engine."""

import re

import addon_utils
import bpy
import pytest

from conftest import ADDON_MODULE, enable_dev_addon


def engine_choices(scene):
    """The Render Engine menu's items, read from the error listing the valid enum values.

    The static `enum_items` of RenderSettings.engine only lists built-in engines; the dynamic
    list (what the menu shows) is what Blender reports for an invalid value.
    """
    with pytest.raises(TypeError) as err:
        scene.render.engine = "NOT_AN_ENGINE"
    return set(re.findall(r"'([A-Z_]+)'", str(err.value)))


def test_engine_in_render_engine_choices(empty_scene):
    assert "CAUSTIC" in engine_choices(empty_scene)
    empty_scene.render.engine = "CAUSTIC"
    assert empty_scene.render.engine == "CAUSTIC"
    assert bpy.types.RenderEngine.bl_rna_get_subclass_py("CAUSTIC").bl_label == "Caustic"


def test_scene_settings_and_preferences_exist(empty_scene):
    settings = empty_scene.caustic
    assert settings.integrator == "path"
    assert settings.samples >= 1
    prefs = bpy.context.preferences.addons[ADDON_MODULE].preferences
    assert hasattr(prefs, "binary_path")


def test_standard_panels_are_opened_to_caustic(addon):
    for name in ("RENDER_PT_format", "RENDER_PT_output", "DATA_PT_lens",
                 "EEVEE_MATERIAL_PT_surface", "DATA_PT_context_light"):
        assert "CAUSTIC" in getattr(bpy.types, name).COMPAT_ENGINES, name
    assert hasattr(bpy.types, "CAUSTIC_PT_render")


def test_unregister_and_register_again(addon):
    addon_utils.disable(ADDON_MODULE, default_set=True)
    try:
        assert bpy.types.RenderEngine.bl_rna_get_subclass_py("CAUSTIC") is None
        assert not hasattr(bpy.types.Scene, "caustic")
        assert "CAUSTIC" not in bpy.types.RENDER_PT_format.COMPAT_ENGINES
        assert ADDON_MODULE not in bpy.context.preferences.addons
    finally:
        module = enable_dev_addon()
    assert module is not None
    assert bpy.types.RenderEngine.bl_rna_get_subclass_py("CAUSTIC") is not None
    assert "CAUSTIC" in bpy.types.RENDER_PT_format.COMPAT_ENGINES
