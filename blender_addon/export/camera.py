"""The camera: lens shift and depth of field, which Blender's glTF exporter drops
(contract: `CAUSTIC_camera`)."""

CAMERA_EXTENSION = "CAUSTIC_camera"


def camera_extension(blender_object, resolution, pixel_aspect=(1.0, 1.0)):
    """Blender's lens shift and depth of field for a camera object (`CAUSTIC_camera`), and warnings.

    The glTF exporter drops both. Shift goes out as fractions of the frame's width and height:
    Blender measures it in units of the sensor-fitted dimension (Cycles' viewplane: dx = 2 *
    aspect * shift_x with the fitted side spanning 2 * aspect). Depth of field as Cycles reads it:
    aperture radius = focal length / (2 f-stop) (focal length in mm, scene units in metres;
    1 / (2 f-stop) for an orthographic camera), focus distance along the viewing axis (to the
    focus object's origin when there is one).
    Returns (value or None, warnings).
    """
    cam = blender_object.data
    warnings = []
    xr = float(resolution[0]) * float(pixel_aspect[0])
    yr = float(resolution[1]) * float(pixel_aspect[1])
    fit = cam.sensor_fit
    horizontal = xr > yr if fit == "AUTO" else fit == "HORIZONTAL"
    if horizontal:
        shift = [cam.shift_x, cam.shift_y * xr / yr]
    else:
        shift = [cam.shift_x * yr / xr, cam.shift_y]
    value = {}
    if cam.shift_x != 0.0 or cam.shift_y != 0.0:
        value["shift"] = [float(s) for s in shift]
    if cam.type == "PANO":
        warnings.append(f"camera '{blender_object.name}': panoramic cameras are not supported; "
                        "rendered as the exporter's perspective camera")
    dof = cam.dof
    if dof.use_dof:
        fstop = max(float(dof.aperture_fstop), 1e-5)
        radius = 1.0 / (2.0 * fstop) if cam.type == "ORTHO" else cam.lens * 1e-3 / (2.0 * fstop)
        if dof.focus_object is not None:
            m = blender_object.matrix_world
            view_dir = m.col[2].xyz.normalized()
            dof_dir = m.translation - dof.focus_object.matrix_world.translation
            focus = abs(view_dir.dot(dof_dir))
            if getattr(dof, "focus_subtarget", ""):
                warnings.append(f"camera '{blender_object.name}': the focus bone is ignored; "
                                "focusing on the object's origin")
        else:
            focus = float(dof.focus_distance)
        value["aperture_radius"] = float(radius)
        value["focus_distance"] = float(max(focus, 1e-6))
        if dof.aperture_blades >= 3:
            value["blades"] = int(dof.aperture_blades)
            value["blade_rotation"] = float(dof.aperture_rotation)
        if dof.aperture_ratio != 1.0:
            value["aperture_ratio"] = float(dof.aperture_ratio)
    return (value or None), warnings
