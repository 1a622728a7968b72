#!/usr/bin/env python3
"""Writes room.gltf: an open-fronted box room (white floor, ceiling and back wall, red left
and green right wall), a white block on the floor that the example moves, a ceiling point
light (KHR_lights_punctual) and a camera looking in. Run it to regenerate the asset."""
import base64, json, struct

def quad(p0, p1, p2, p3, n):
    """Two triangles over corners p0..p3 (counter-clockwise seen from the normal's side)."""
    return [p0, p1, p2, p3], [n] * 4, [0, 1, 2, 0, 2, 3]

def box(lo, hi):
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    faces = [
        quad((x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0), (0, 1, 0)),
        quad((x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1), (0, -1, 0)),
        quad((x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1), (0, 0, 1)),
        quad((x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (0, 0, -1)),
        quad((x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (1, 0, 0)),
        quad((x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0), (-1, 0, 0)),
    ]
    return merge(faces)

def merge(parts):
    pos, nrm, idx = [], [], []
    for p, n, i in parts:
        idx += [len(pos) + k for k in i]
        pos += p
        nrm += n
    return pos, nrm, idx

S = 2.0
room = {
    "white": merge([
        quad((0, 0, 0), (0, 0, S), (S, 0, S), (S, 0, 0), (0, 1, 0)),  # floor
        quad((0, S, 0), (S, S, 0), (S, S, S), (0, S, S), (0, -1, 0)),  # ceiling
        quad((0, 0, 0), (S, 0, 0), (S, S, 0), (0, S, 0), (0, 0, 1)),  # back wall
    ]),
    "red": merge([quad((0, 0, 0), (0, S, 0), (0, S, S), (0, 0, S), (1, 0, 0))]),
    "green": merge([quad((S, 0, 0), (S, 0, S), (S, S, S), (S, S, 0), (-1, 0, 0))]),
}
block = box((-0.25, 0.0, -0.25), (0.25, 0.6, 0.25))

blob = bytearray()
accessors, views = [], []

def add(data, fmt, count, target, kind, extra=None):
    while len(blob) % 4:
        blob.append(0)
    offset = len(blob)
    blob.extend(struct.pack("<" + fmt * count, *data))
    views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(blob) - offset, "target": target})
    acc = {"bufferView": len(views) - 1, "componentType": 5126 if fmt == "f" else 5125,
           "count": count // (3 if kind == "VEC3" else 1), "type": kind}
    if extra:
        acc.update(extra)
    accessors.append(acc)
    return len(accessors) - 1

def primitive(mesh, material):
    pos, nrm, idx = mesh
    flat_p = [c for p in pos for c in p]
    lo = [min(p[k] for p in pos) for k in range(3)]
    hi = [max(p[k] for p in pos) for k in range(3)]
    a_p = add(flat_p, "f", len(flat_p), 34962, "VEC3", {"min": lo, "max": hi})
    a_n = add([c for n in nrm for c in n], "f", len(flat_p), 34962, "VEC3")
    a_i = add(idx, "I", len(idx), 34963, "SCALAR")
    return {"attributes": {"POSITION": a_p, "NORMAL": a_n}, "indices": a_i, "material": material}

materials = [
    {"name": "white", "pbrMetallicRoughness": {"baseColorFactor": [0.75, 0.75, 0.75, 1], "metallicFactor": 0}},
    {"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.08, 0.06, 1], "metallicFactor": 0}},
    {"name": "green", "pbrMetallicRoughness": {"baseColorFactor": [0.12, 0.6, 0.1, 1], "metallicFactor": 0}},
]
meshes = [
    {"name": "room", "primitives": [primitive(room["white"], 0), primitive(room["red"], 1), primitive(room["green"], 2)]},
    {"name": "block", "primitives": [primitive(block, 0)]},
]
gltf = {
    "asset": {"version": "2.0", "generator": "octolux examples/deferred/assets/make_room.py"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [
        # 3 W/sr in octolux's radiometric units (683 lm/W).
        {"name": "lamp", "type": "point", "color": [1, 0.95, 0.85], "intensity": 3 * 683},
    ]}},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2, 3]}],
    "nodes": [
        {"name": "room", "mesh": 0},
        {"name": "block", "mesh": 1, "translation": [0.7, 0.0, 0.9]},
        {"name": "lamp", "translation": [1.0, 1.85, 1.0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
        {"name": "camera", "camera": 0, "translation": [1.0, 1.0, 4.2]},
    ],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.75, "znear": 0.05, "zfar": 50.0, "aspectRatio": 1.0}}],
    "meshes": meshes,
    "materials": materials,
    "accessors": accessors,
    "bufferViews": views,
    "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()}],
}
with open(__file__.replace("make_room.py", "room.gltf"), "w") as f:
    json.dump(gltf, f, indent=1)
