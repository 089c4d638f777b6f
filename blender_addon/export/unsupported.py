"""What Caustic cannot render yet, named: scene features that would otherwise be dropped without
a word (hair, volume objects, shadow catcher, lights' ray visibility beyond Camera, shadow
linking (blockers), view layer indirect-only collections, material override; Holdout goes out with
visibility.py, with a warning from the BDPT run that cannot render it). Each warning
names the object, collection or setting and says what the render does instead."""

# A light's Ray Visibility beyond Camera (which lights.py exports): Cycles excludes the hidden
# kinds' closures from the light's next-event estimation, which Caustic's BSDFs cannot yet.
_LIGHT_RAY_VISIBILITY = (("visible_diffuse", "diffuse"), ("visible_glossy", "glossy"),
                         ("visible_transmission", "transmission"), ("visible_volume_scatter", "volume scatter"))


def scene_warnings(depsgraph):
    """Warnings for everything in the render depsgraph's scene that Caustic does not render."""
    scene = depsgraph.scene
    view_layer = depsgraph.view_layer
    warnings = []
    warnings += _collection_warnings(view_layer.layer_collection, view_layer.name)
    seen = set()
    for instance in depsgraph.object_instances:
        obj = instance.instance_object if instance.is_instance else instance.object
        original = obj.original
        if original.name in seen:
            continue
        seen.add(original.name)
        warnings += object_warnings(original)
    return warnings


def object_warnings(obj):
    """Warnings for one object's features that Caustic does not render."""
    what = f"object '{obj.name}'"
    warnings = []
    if obj.type == "CURVES":
        warnings.append(f"{what}: hair curves are not rendered")
    elif obj.type == "VOLUME":
        warnings.append(f"{what}: volume objects (OpenVDB grids) are not rendered")
    elif obj.type == "POINTCLOUD":
        warnings.append(f"{what}: point clouds are not rendered")
    for modifier in getattr(obj, "modifiers", ()):
        if modifier.type == "PARTICLE_SYSTEM" and modifier.show_render:
            settings = modifier.particle_system.settings
            if settings.type == "HAIR" and settings.render_type == "PATH":
                warnings.append(f"{what}: hair particle system '{modifier.particle_system.name}' is not rendered")
    # Blender 5.0 sets the flag on new lights too; it means something for geometry only.
    if obj.type not in ("LIGHT", "CAMERA", "EMPTY") and getattr(obj, "is_shadow_catcher", False):
        warnings.append(f"{what}: Shadow Catcher is not supported; it renders as an ordinary object")
    if obj.type == "LIGHT":
        hidden = [name for prop, name in _LIGHT_RAY_VISIBILITY if not getattr(obj, prop, True)]
        if hidden:
            warnings.append(f"light '{obj.name}': ray visibility off for {', '.join(hidden)} is ignored "
                            "(the light lights every surface)")
    linking = getattr(obj, "light_linking", None)
    if linking is not None and linking.blocker_collection is not None:
        warnings.append(f"{what}: shadow linking (blocker collection) is ignored; every object blocks its light")
    return warnings


def _collection_warnings(layer_collection, layer_name):
    """Holdout and Indirect Only collections of the view layer, which Caustic renders as ordinary."""
    warnings = []
    for child in layer_collection.children:
        if child.exclude:
            continue
        for flag, label in (("indirect_only", "Indirect Only"),):
            if getattr(child, flag, False):
                warnings.append(f"view layer '{layer_name}': collection '{child.name}' is {label}, which is not "
                                "supported; it renders as ordinary")
        warnings += _collection_warnings(child, layer_name)
    return warnings
