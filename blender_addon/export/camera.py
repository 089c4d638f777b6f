"""The camera: lens shift, depth of field and panoramic cameras, which Blender's glTF exporter
drops (contract: `CAUSTIC_camera`)."""

CAMERA_EXTENSION = "CAUSTIC_camera"


def lens_shift(cam, shift_x, resolution, pixel_aspect):
    """The contract's `shift` of camera data `cam` with Shift X `shift_x` (its own, or a
    stereo eye's), or None when both shifts are 0 (see `camera_extension`)."""
    if shift_x == 0.0 and cam.shift_y == 0.0:
        return None
    if cam.type == "PANO":
        return [float(shift_x), float(cam.shift_y)]
    xr = float(resolution[0]) * float(pixel_aspect[0])
    yr = float(resolution[1]) * float(pixel_aspect[1])
    horizontal = xr > yr if cam.sensor_fit == "AUTO" else cam.sensor_fit == "HORIZONTAL"
    if horizontal:
        return [float(shift_x), float(cam.shift_y) * xr / yr]
    return [float(shift_x) * yr / xr, float(cam.shift_y)]


def fit_orthographic(gltf2_camera, cam, resolution, pixel_aspect=(1.0, 1.0)):
    """Set an orthographic glTF camera's xmag and ymag from Blender's Orthographic Scale as
    Cycles fits it to the frame: along the width for Sensor Fit Horizontal, the height for
    Vertical, the longer side for Auto. Blender's exporter always takes the longer side, so a
    Vertical fit on a landscape frame (or Horizontal on a portrait one) came out wider or
    narrower than Cycles' view by the frame's aspect."""
    ortho = getattr(gltf2_camera, "orthographic", None) if gltf2_camera is not None else None
    if cam.type != "ORTHO" or ortho is None:
        return
    xr = float(resolution[0]) * float(pixel_aspect[0])
    yr = float(resolution[1]) * float(pixel_aspect[1])
    horizontal = xr > yr if cam.sensor_fit == "AUTO" else cam.sensor_fit == "HORIZONTAL"
    half = float(cam.ortho_scale) / 2.0
    ortho.xmag, ortho.ymag = (half, half * yr / xr) if horizontal else (half * xr / yr, half)


def camera_extension(blender_object, resolution, pixel_aspect=(1.0, 1.0)):
    """Blender's lens shift and depth of field for a camera object (`CAUSTIC_camera`), and warnings.

    The glTF exporter drops both. Shift goes out as fractions of the frame's width and height:
    Blender measures it in units of the sensor-fitted dimension (Cycles' viewplane: dx = 2 *
    aspect * shift_x with the fitted side spanning 2 * aspect). Depth of field as Cycles reads it:
    aperture radius = focal length / (2 f-stop) (focal length in mm, scene units in metres;
    1 / (2 f-stop) for an orthographic camera), focus distance along the viewing axis (to the
    focus object's origin when there is one).
    A panoramic camera, for which the exporter writes no glTF camera at all, goes out whole:
    its type and settings (`panorama_extension`), its clip start and end, and its shift unscaled
    (Cycles moves a panoramic camera's unit viewplane by the shift itself).
    Returns (value or None, warnings).
    """
    cam = blender_object.data
    warnings = []
    xr = float(resolution[0]) * float(pixel_aspect[0])
    yr = float(resolution[1]) * float(pixel_aspect[1])
    value = {}
    if cam.type == "PANO":
        value["panorama"] = panorama_extension(cam, xr, yr)
        value["clip"] = [float(cam.clip_start), float(cam.clip_end)]
    shift = lens_shift(cam, cam.shift_x, resolution, pixel_aspect)
    if shift is not None:
        value["shift"] = shift
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


def panorama_extension(cam, xr, yr):
    """`CAUSTIC_camera.panorama`: the panoramic type and the settings Cycles reads for it
    (blender/camera.cpp). The equisolid and polynomial fisheyes' sensor is fitted to the frame
    as Cycles fits it: the fitted side keeps the sensor size, the other follows the frame's
    aspect (`xr`, `yr`: resolution times pixel aspect); Auto takes the sensor width and fits it
    to the longer side."""
    kind = cam.panorama_type.lower()
    value = {"type": kind}
    if kind in ("fisheye_equidistant", "fisheye_equisolid", "fisheye_lens_polynomial"):
        value["fov"] = float(cam.fisheye_fov)
    if kind in ("fisheye_equisolid", "fisheye_lens_polynomial"):
        if cam.sensor_fit == "AUTO":
            horizontal, size = xr > yr, cam.sensor_width
        elif cam.sensor_fit == "HORIZONTAL":
            horizontal, size = True, cam.sensor_width
        else:
            horizontal, size = False, cam.sensor_height
        value["sensor"] = [float(size), float(size * yr / xr)] if horizontal else [float(size * xr / yr), float(size)]
    if kind == "fisheye_equisolid":
        value["lens"] = float(cam.fisheye_lens)
    elif kind == "fisheye_lens_polynomial":
        value["polynomial"] = [float(getattr(cam, f"fisheye_polynomial_k{i}")) for i in range(5)]
    elif kind == "equirectangular":
        value["latitude"] = [float(cam.latitude_min), float(cam.latitude_max)]
        value["longitude"] = [float(cam.longitude_min), float(cam.longitude_max)]
    elif kind == "central_cylindrical":
        radius = float(cam.central_cylindrical_radius)
        value["u_range"] = [float(cam.central_cylindrical_range_u_min), float(cam.central_cylindrical_range_u_max)]
        # Cycles divides the height range by the cylinder's radius (blender/camera.cpp).
        value["v_range"] = [float(cam.central_cylindrical_range_v_min) / radius,
                            float(cam.central_cylindrical_range_v_max) / radius]
    return value
