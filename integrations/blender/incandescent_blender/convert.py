"""Blender → incandescent, in plain Python (no bpy: tested outside Blender too).

Blender's world is right-handed with +Z up; ours is right-handed with +Y up (DESIGN.md §4), and
``incandescent render --preset blender`` (or ``--up-axis z``) reads a file's point (x, y, z) as
ours (x, z, −y). A Blender camera looks down its local −Z with local +Y up and +X right
(Blender manual, Camera object). Its field of view follows the *sensor fit*: Auto fits the
sensor width to the larger image side, Horizontal to the width, Vertical the sensor height to the
height; an orthographic camera's Orthographic Scale is the fitted side in scene units (metres).
"""

import math

Matrix = list  # 4×4, rows, as list(map(list, bpy_matrix))


def to_ours(v):
    """Blender's (x, y, z), z up → ours (x, z, −y), y up."""
    return (float(v[0]), float(v[2]), -float(v[1]))


def inverse_rigid(m):
    """The inverse of a rotation+translation 4×4 (the rotation's transpose)."""
    r = [[m[j][i] for j in range(3)] for i in range(3)]
    t = [-sum(r[i][k] * m[k][3] for k in range(3)) for i in range(3)]
    return [r[0] + [t[0]], r[1] + [t[1]], r[2] + [t[2]], [0.0, 0.0, 0.0, 1.0]]


def multiply(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def _unit(v):
    n = math.sqrt(sum(c * c for c in v))
    return [c / n for c in v]


def scale_of(m):
    """The lengths of the 3×3 part's columns (the object's scale along its axes)."""
    return [math.sqrt(sum(m[i][j] ** 2 for i in range(3))) for j in range(3)]


def rigid_part(m):
    """``m`` without its scale (unit columns), and that scale."""
    scale = scale_of(m)
    out = [[m[i][j] / scale[j] if j < 3 else m[i][j] for j in range(4)] for i in range(3)]
    return out + [[0.0, 0.0, 0.0, 1.0]], scale


def fitted_fov_deg(lens_mm, sensor_width_mm, sensor_height_mm, fit, width, height):
    """Our vertical field of view for a perspective Blender camera (degrees)."""
    fit = fit if fit != "AUTO" else ("HORIZONTAL" if width >= height else "VERTICAL_WIDTH")
    if fit == "HORIZONTAL":
        half_w = sensor_width_mm / (2.0 * lens_mm)
        half_h = half_w * height / width
    elif fit == "VERTICAL_WIDTH":  # Auto on a tall image: the sensor *width* spans the height
        half_h = sensor_width_mm / (2.0 * lens_mm)
    else:
        half_h = sensor_height_mm / (2.0 * lens_mm)
    return math.degrees(2.0 * math.atan(half_h))


def fitted_ortho_height(ortho_scale, fit, width, height):
    """Our orthographic view height (m) for Blender's Orthographic Scale."""
    if fit == "AUTO":
        fit = "HORIZONTAL" if width >= height else "VERTICAL"
    return ortho_scale * height / width if fit == "HORIZONTAL" else ortho_scale


def camera_arguments(camera_matrix, frame_matrix, data, width, height):
    """``incandescent render`` camera options for a Blender camera, in the frame of the volume
    file: ``frame_matrix`` maps the file's coordinates to Blender's world (the object's
    matrix_world, times the cache's offset for a fluid domain). ``data``: the camera's lens,
    sensor sizes, sensor fit, type and ortho_scale (a dict). Raises ValueError for what our
    camera cannot be: lens shift, panoramic cameras, a scaled frame."""
    if abs(data["shift_x"]) > 0 or abs(data["shift_y"]) > 0:
        raise ValueError(
            "the camera has a lens shift; incandescent's camera has none (set Shift X/Y to 0)"
        )
    if data["type"] not in ("PERSP", "ORTHO"):
        raise ValueError(
            f"the camera is {data['type']}; incandescent renders perspective and orthographic "
            "cameras"
        )
    frame, scale = rigid_part(frame_matrix)
    if any(abs(s - 1.0) > 1e-6 for s in scale):
        raise ValueError(
            f"the volume object is scaled {tuple(round(s, 6) for s in scale)}; apply its scale "
            "(Object › Apply › Scale) so the file's metres are the scene's"
        )
    local = multiply(inverse_rigid(frame), rigid_part(camera_matrix)[0])
    eye = [local[i][3] for i in range(3)]
    forward = _unit([-local[i][2] for i in range(3)])
    up = _unit([local[i][1] for i in range(3)])
    target = [eye[i] + forward[i] for i in range(3)]
    args = [
        "--eye",
        _triple(to_ours(eye)),
        "--target",
        _triple(to_ours(target)),
        "--up",
        _triple(to_ours(up)),
    ]
    args += ["--width", str(width), "--height", str(height)]
    fit = data["sensor_fit"]
    if data["type"] == "ORTHO":
        height_m = fitted_ortho_height(data["ortho_scale"], fit, width, height)
        return args + ["--projection", "orthographic", "--ortho-height", repr(height_m)]
    fov = fitted_fov_deg(
        data["lens"], data["sensor_width"], data["sensor_height"], fit, width, height
    )
    return args + ["--fov", repr(fov)]


def _triple(v):
    return ",".join(repr(float(c)) for c in v)


def domain_offset(bound_box_min, dimensions_local, resolution_max):
    """A Mantaflow cache's file → domain-local translation. Its cells are cubes of side
    dx = the domain's longest side / Resolution Divisions (``resolution_max``); the cache's voxel
    (0, 0, 0) is centred at the file's origin and is the domain box's first cell, centred half a
    cell inside the box's lower corner (``bound_box_min``, local)."""
    cell = max(dimensions_local) / resolution_max
    return [bound_box_min[i] + 0.5 * cell for i in range(3)]


def translation(offset):
    return [
        [1.0, 0.0, 0.0, offset[0]],
        [0.0, 1.0, 0.0, offset[1]],
        [0.0, 0.0, 1.0, offset[2]],
        [0.0, 0.0, 0.0, 1.0],
    ]
