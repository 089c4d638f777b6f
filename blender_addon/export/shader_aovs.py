"""The view layer's shader AOVs as the render settings' `shader_aovs` (docs/contract.md): each valid
AOV's name and type in the view layer's order, and the layer's Alpha Threshold, which ends the
camera ray's AOV writes at the first surface at least that opaque (Cycles' rule). Cycles leaves out
an AOV that is not valid (a name used twice or taken by a pass); so does this, with a warning."""


def valid_aovs(view_layer):
    """The view layer's AOVs that Cycles renders (`is_valid`), in order."""
    return [aov for aov in getattr(view_layer, "aovs", ()) if aov.is_valid]


def shader_aov_settings(view_layer):
    """(the `shader_aovs` settings or None without valid AOVs, warnings naming the invalid ones)."""
    warnings = [f"the shader AOV '{aov.name}' is not valid (its name is used twice or by a pass); "
                "it is not rendered, as in Cycles" for aov in getattr(view_layer, "aovs", ()) if not aov.is_valid]
    aovs = [{"name": aov.name, "type": aov.type} for aov in valid_aovs(view_layer)]
    if not aovs:
        return None, warnings
    return {"aovs": aovs, "alpha_threshold": float(view_layer.pass_alpha_threshold)}, warnings
