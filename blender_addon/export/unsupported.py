"""What Caustic cannot render yet, named: scene features that would otherwise be dropped without
a word (lights' ray visibility beyond Camera, material
override; shadow linking goes out with light_linking.py; Holdout, Indirect Only collections and Shadow
Catcher go out with visibility.py, with a warning from the runs of integrators that cannot render
them). Each warning
names the object, collection or setting and says what the render does instead."""

# A light's Ray Visibility beyond Camera (which lights.py exports): Cycles excludes the hidden
# kinds' closures from the light's next-event estimation, which Caustic's BSDFs cannot yet.
_LIGHT_RAY_VISIBILITY = (("visible_diffuse", "diffuse"), ("visible_glossy", "glossy"),
                         ("visible_transmission", "transmission"), ("visible_volume_scatter", "volume scatter"))


def scene_warnings(depsgraph):
    """Warnings for everything in the render depsgraph's scene that Caustic does not render."""
    warnings = []
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
    if obj.type == "POINTCLOUD":
        warnings.append(f"{what}: point clouds are not rendered")
    if obj.type == "LIGHT":
        hidden = [name for prop, name in _LIGHT_RAY_VISIBILITY if not getattr(obj, prop, True)]
        if hidden:
            warnings.append(f"light '{obj.name}': ray visibility off for {', '.join(hidden)} is ignored "
                            "(the light lights every surface)")
    return warnings

