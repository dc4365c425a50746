"""Writes a Mitsuba 3 scene dictionary as glTF 2.0 (.gltf + .bin) that `gi` renders the same way.

Only what the Cornell box uses is supported, and anything else is refused with a clear error
rather than approximated:

- shapes: `rectangle` (Mitsuba's [-1,1]^2 square in the XY plane, normal +Z, before
  `to_world`) and any shape Mitsuba loads as a triangle mesh (`cube`, `obj`, `ply`, ...);
- BSDFs: `diffuse` with a constant `rgb` reflectance, inline or by `ref`;
- emitters: `area` with a constant `rgb` radiance on a shape;
- the sensor: `perspective` with `fov` / `fov_axis` and `to_world`.

Every triangle is written in world space with its flat normal and with the winding that makes
Mitsuba's normal its glTF front face: Mitsuba's area emitters emit on the normal's side only,
and our single-sided emitters emit on the front face only. Each material is a pure Lambert
surface in glTF terms: `baseColorFactor` = Mitsuba's reflectance, metallic 0, roughness 1, and
`KHR_materials_specular` with `specularFactor` 0 (without it glTF adds a 4% GGX layer that
Mitsuba's `diffuse` does not have). An emitter's radiance becomes `emissiveFactor` (in 0..1)
times `KHR_materials_emissive_strength`. The scene's `extras.gi` ask for a black sky and an
exposure of 1, so nothing lights the box but its emitter.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import mitsuba as mi
import numpy as np

MESH_SHAPES = {"cube", "obj", "ply", "serialized"}
"""Shapes Mitsuba loads as triangle meshes (their triangles are read back from Mitsuba)."""
NOT_GEOMETRY_KEYS = {"type", "integrator", "sensor"}
BSDF_TYPES = {"diffuse", "twosided"}
"""Top-level BSDFs are read where a shape refers to them."""


class UnsupportedScene(ValueError):
    """The scene uses something this exporter cannot state in glTF without changing it."""


def _matrix(transform) -> np.ndarray:
    """4x4 float64 matrix of a Mitsuba transform (identity when absent)."""
    if transform is None:
        return np.eye(4)
    return np.array(transform.matrix, dtype=np.float64).reshape(4, 4)


def _rectangle_triangles(world_from_local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World-space corners (2 triangles x 3) of Mitsuba's rectangle and its world normal."""
    corners = np.array([[-1, -1, 0, 1], [1, -1, 0, 1], [1, 1, 0, 1], [-1, 1, 0, 1]], float)
    world = (world_from_local @ corners.T).T[:, :3]
    triangles = world[[0, 1, 2, 0, 2, 3]].reshape(2, 3, 3)
    # Normals transform by the inverse transpose, as Mitsuba does.
    normal = np.linalg.inv(world_from_local[:3, :3]).T @ np.array([0.0, 0.0, 1.0])
    return triangles, normal / np.linalg.norm(normal)


def _mesh_triangles(shape_dict: dict) -> tuple[np.ndarray, np.ndarray]:
    """World-space triangles of a shape Mitsuba loads as a mesh, with its per-triangle normals
    (Mitsuba's vertex normals averaged, or the winding's when it has none)."""
    plain = {k: v for k, v in shape_dict.items() if k not in ("bsdf", "emitter")}
    mesh = mi.load_dict(plain)
    if not isinstance(mesh, mi.Mesh):
        raise UnsupportedScene(f"shape type {shape_dict['type']!r} is not a triangle mesh")
    positions = np.array(mesh.vertex_positions_buffer(), dtype=np.float64).reshape(-1, 3)
    faces = np.array(mesh.faces_buffer(), dtype=np.int64).reshape(-1, 3)
    triangles = positions[faces]
    if mesh.has_vertex_normals():
        vertex_normals = np.array(mesh.vertex_normals_buffer(), np.float64).reshape(-1, 3)
        normals = vertex_normals[faces].sum(axis=1)
    else:
        normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    return triangles, normals / np.linalg.norm(normals, axis=1, keepdims=True)


def _front_facing(triangles: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangles wound counter-clockwise about `normals` (swapping two corners where not), and
    their flat unit normals."""
    normals = np.broadcast_to(normals, (len(triangles), 3))
    winding = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    flip = np.einsum("ij,ij->i", winding, normals) < 0
    triangles = triangles.copy()
    triangles[flip] = triangles[flip][:, [0, 2, 1]]
    winding[flip] = -winding[flip]
    return triangles, winding / np.linalg.norm(winding, axis=1, keepdims=True)


def _rgb(value, what: str) -> list[float]:
    """A constant colour of a Mitsuba property (an `rgb` dict, a scalar or a triple)."""
    if isinstance(value, dict):
        if value.get("type") != "rgb":
            raise UnsupportedScene(f"{what}: only constant rgb values are supported")
        value = value["value"]
    if isinstance(value, (int, float)):
        return [float(value)] * 3
    rgb = [float(c) for c in value]
    if len(rgb) != 3:
        raise UnsupportedScene(f"{what}: expected 3 components, got {len(rgb)}")
    return rgb


def _resolve(scene: dict, value: dict, inline_name: str) -> tuple[str, dict]:
    """(name, dict) of a `ref` to a top-level object, or of an inline one (named
    `inline_name`)."""
    if value.get("type") == "ref":
        return value["id"], scene[value["id"]]
    return inline_name, value


def _lambert_material(name: str, bsdf: dict) -> dict:
    if bsdf.get("type") == "twosided":
        bsdf = bsdf["bsdf"]  # our surfaces reflect on both sides anyway
    if bsdf.get("type") != "diffuse":
        raise UnsupportedScene(
            f"BSDF {name!r}: only 'diffuse' is supported, not {bsdf.get('type')!r}")
    reflectance = _rgb(bsdf.get("reflectance", 0.5), f"BSDF {name!r} reflectance")
    return {
        "name": name,
        "pbrMetallicRoughness": {
            "baseColorFactor": reflectance + [1.0],
            "metallicFactor": 0.0,
            "roughnessFactor": 1.0,
        },
        # Mitsuba's diffuse is one-sided; so is this (our renderer reflects on both sides,
        # which only matters for surfaces nothing in the box can see from behind).
        "doubleSided": False,
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}},
    }


def _with_emission(material: dict, radiance: list[float]) -> dict:
    strength = max(radiance)
    material = json.loads(json.dumps(material))
    material["name"] += " (emitter)"
    if strength > 0:
        material["emissiveFactor"] = [c / strength for c in radiance]
        material["extensions"]["KHR_materials_emissive_strength"] = {"emissiveStrength": strength}
    return material


def _camera(sensor: dict, width: int, height: int) -> tuple[dict, dict]:
    """glTF camera and its node for Mitsuba's perspective sensor.

    Mitsuba's camera looks down its local +Z with +Y up and +X to the image's *left*; glTF's
    looks down -Z with +Y up and +X to the right. So glTF's right, up and back axes are
    Mitsuba's -X, +Y and -Z, a proper rotation (Mitsuba's frame is left-handed in that sense).
    """
    if sensor.get("type") != "perspective":
        raise UnsupportedScene(
            f"sensor type {sensor.get('type')!r}: only 'perspective' is supported")
    world_from_camera = _matrix(sensor.get("to_world"))
    axes = world_from_camera[:3, :3]
    scale = np.linalg.norm(axes, axis=0)
    if not np.allclose(scale, 1.0, atol=1e-5):
        raise UnsupportedScene(f"sensor to_world is scaled ({scale}); only rotations are supported")
    rotation = axes / scale * np.array([-1.0, 1.0, -1.0])
    if np.linalg.det(rotation) < 0:
        raise UnsupportedScene("sensor to_world is mirrored; a glTF camera cannot be")

    aspect = width / height
    fov_axis = sensor.get("fov_axis", "x")
    tan_half = math.tan(math.radians(float(sensor["fov"])) / 2)
    if fov_axis == "smaller":
        fov_axis = "x" if width < height else "y"
    elif fov_axis == "larger":
        fov_axis = "x" if width > height else "y"
    if fov_axis == "x":
        tan_half_y = tan_half / aspect
    elif fov_axis == "y":
        tan_half_y = tan_half
    elif fov_axis == "diagonal":
        tan_half_y = tan_half / math.sqrt(1 + aspect * aspect)
    else:
        raise UnsupportedScene(f"sensor fov_axis {fov_axis!r} is not understood")

    camera = {
        "name": "Camera",
        "type": "perspective",
        "perspective": {
            "yfov": 2 * math.atan(tan_half_y),
            "aspectRatio": aspect,
            "znear": float(sensor.get("near_clip", 0.01)),
        },
    }
    node = {
        "name": "Camera",
        "camera": 0,
        "rotation": _quaternion(rotation),
        "translation": world_from_camera[:3, 3].tolist(),
    }
    return camera, node


def _quaternion(m: np.ndarray) -> list[float]:
    """glTF (x, y, z, w) unit quaternion of a rotation matrix (Shepperd's method)."""
    trace = np.trace(m)
    if trace > 0:
        s = 2 * math.sqrt(1 + trace)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2 * math.sqrt(1 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0] * 4
        q[i] = s / 4
        q[j] = (m[j, i] + m[i, j]) / s
        q[k] = (m[k, i] + m[i, k]) / s
        q[3] = (m[k, j] - m[j, k]) / s
    q = np.array(q) / np.linalg.norm(q)
    return q.tolist()


def export_gltf(scene: dict, width: int, height: int, path: Path) -> dict:
    """Writes `scene` (a Mitsuba scene dict) as `path` (.gltf) and `path` with .bin beside it.

    Returns a short description: shape and triangle counts and the camera's yfov in degrees.
    """
    materials: list[dict] = []
    material_index: dict[str, int] = {}
    meshes, nodes, blob = [], [], bytearray()
    accessors, views = [], []
    triangle_count = 0

    def add_array(data: np.ndarray, target: int) -> int:
        data = np.ascontiguousarray(data, dtype=np.float32)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": data.nbytes,
                      "target": target})
        blob.extend(data.tobytes())
        accessors.append({"bufferView": len(views) - 1, "componentType": 5126,
                          "count": len(data), "type": "VEC3",
                          "min": data.min(axis=0).tolist(), "max": data.max(axis=0).tolist()})
        return len(accessors) - 1

    for name, shape in scene.items():
        if name in NOT_GEOMETRY_KEYS or shape.get("type") in BSDF_TYPES:
            continue
        if shape.get("type") == "rectangle":
            triangles, normal = _rectangle_triangles(_matrix(shape.get("to_world")))
        elif shape.get("type") in MESH_SHAPES:
            triangles, normal = _mesh_triangles(shape)
        else:
            # An environment or punctual emitter, a sphere...: the comparison would be wrong
            # without it, so refuse rather than drop it.
            raise UnsupportedScene(f"{name!r}: object type {shape.get('type')!r} is not supported")
        triangles, normals = _front_facing(triangles, normal)

        bsdf_id, bsdf = _resolve(scene, shape.get("bsdf", {"type": "diffuse"}), f"{name}.bsdf")
        key = bsdf_id
        material = _lambert_material(bsdf_id, bsdf)
        emitter = shape.get("emitter")
        if emitter is not None:
            if emitter.get("type") != "area":
                raise UnsupportedScene(f"shape {name!r}: only 'area' emitters are supported")
            material = _with_emission(material, _rgb(emitter["radiance"], f"{name!r} radiance"))
            key = f"{bsdf_id}+emitter:{name}"
        if key not in material_index:
            material_index[key] = len(materials)
            materials.append(material)

        positions = triangles.reshape(-1, 3)
        corner_normals = np.repeat(normals, 3, axis=0)
        position_accessor = add_array(positions, 34962)
        normal_accessor = add_array(corner_normals, 34962)
        meshes.append({"name": name, "primitives": [{
            "attributes": {"POSITION": position_accessor, "NORMAL": normal_accessor},
            "material": material_index[key], "mode": 4}]})
        nodes.append({"name": name, "mesh": len(meshes) - 1})
        triangle_count += len(triangles)

    camera, camera_node = _camera(scene["sensor"], width, height)
    nodes.append(camera_node)
    bin_path = path.with_suffix(".bin")
    document = {
        "asset": {"version": "2.0", "generator": "benchmarks/mitsuba/mitsuba_gltf.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_materials_specular"],
        "scene": 0,
        "scenes": [{
            "name": "mitsuba-cornell-box",
            "nodes": list(range(len(nodes))),
            "extras": {"gi": {"sky": {"constant": [0.0, 0.0, 0.0]}, "exposure": 1.0,
                              "camera": "Camera"}},
        }],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "cameras": [camera],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob), "uri": bin_path.name}],
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    bin_path.write_bytes(bytes(blob))
    path.write_text(json.dumps(document, indent=1))
    return {
        "shapes": len(meshes),
        "triangles": triangle_count,
        "yfov_deg": math.degrees(camera["perspective"]["yfov"]),
    }
