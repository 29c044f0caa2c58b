#!/usr/bin/env python3
"""Writes the binary and generated test meshes of tests/data/scene (run from anywhere).

The outputs are committed; this script documents how they were made and regenerates them:
  meshes/quad_tri_ascii.ply, quad_tri_le.ply, quad_tri_be.ply, quad_tri.ply.gz
      one mesh (a quad and a triangle, 5 vertices with normals and texture coordinates) written
      three ways with different property types and names; all must load equal.
  meshes/lights.gltf, meshes/lights.glb
      a node hierarchy with transforms, four materials (diffuse, mirror, glass, emissive),
      index accessors of three component types and KHR_lights_punctual point/spot/directional.
  bad/*.ply, bad/*.gz
      broken PLY files, one per error class (see scene tests).
  meshes/ply_variants/extras_ascii.ply, extras_le.ply
      the quad_tri mesh with the header extras other exporters write: CRLF line ends, blank
      lines, obj_info and comments between any lines, tabs and padding, sized type aliases,
      colour and alpha vertex properties, extra face properties and an unknown element with data
      between vertex and face. Both must load equal to quad_tri_ascii.ply.
  meshes/strips_fans.gltf, bad/short_strip.gltf, bad/unknown_mode.gltf
      TRIANGLE_STRIP and TRIANGLE_FAN primitives, indexed and not, with stitching (degenerate)
      triangles, plus a LINES primitive to skip; a strip of two vertices; a mode glTF lacks.
  meshes/camera_light.gltf
      a quad with a perspective and an orthographic camera and two KHR_lights_punctual lights,
      for the bare-mesh scene (mesh_scene.h).
  meshes/volume.gltf
      glass cubes with KHR_materials_volume (one at scale 2), a glass cube whose volume absorbs
      nothing, and an open sheet of the absorbing glass, which cannot enclose its medium.
  bad/gltf1_no_asset.gltf, bad/garbage.fbx, bad/truncated.stl
      a glTF 1.0 document recognisable only by its top-level objects, text that is no FBX, and a
      binary STL that claims 1000 facets but holds one.
Real files from other tools are in thirdparty/ (README.md there), copied, not generated.
"""

import base64
import gzip
import json
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
MESHES = os.path.join(HERE, "meshes")
BAD = os.path.join(HERE, "bad")

# (position, normal, uv); exactly representable in float so every encoding loads equal.
VERTICES = [
    ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0)),
    ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (1.0, 0.0)),
    ((1.0, 1.0, 0.0), (0.0, 0.0, 1.0), (1.0, 1.0)),
    ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 1.0)),
    ((0.5, 2.0, 0.25), (0.0, 0.0, 1.0), (0.5, 1.0)),
]
FACES = [[0, 1, 2, 3], [3, 2, 4]]


def write(path, data):
    mode = "w" if isinstance(data, str) else "wb"
    with open(path, mode) as f:
        f.write(data)


def ply_ascii(faces=FACES, vertices=VERTICES):
    lines = [
        "ply",
        "format ascii 1.0",
        "comment written by make_test_meshes.py",
        f"element vertex {len(vertices)}",
        "property float x",
        "property float y",
        "property float z",
        "property float nx",
        "property float ny",
        "property float nz",
        "property float u",
        "property float v",
        f"element face {len(faces)}",
        "property list uchar int vertex_indices",
        "end_header",
    ]
    for p, n, uv in vertices:
        lines.append(" ".join(f"{x:g}" for x in (*p, *n, *uv)))
    for face in faces:
        lines.append(" ".join(str(x) for x in [len(face), *face]))
    return "\n".join(lines) + "\n"


def ply_le(faces=FACES):
    """Little-endian, float positions, s/t names, extra properties and elements to skip."""
    header = "\n".join([
        "ply",
        "format binary_little_endian 1.0",
        f"element vertex {len(VERTICES)}",
        "property float x",
        "property float y",
        "property float z",
        "property float confidence",
        "property float nx",
        "property float ny",
        "property float nz",
        "property float s",
        "property float t",
        f"element face {len(faces)}",
        "property list uchar int vertex_indices",
        "property uchar flags",
        "element edge 2",
        "property int vertex1",
        "property int vertex2",
        "element tag 1",
        "property list ushort float values",
        "end_header",
    ]) + "\n"
    body = b""
    for p, n, uv in VERTICES:
        body += struct.pack("<3ff3f2f", *p, 0.5, *n, *uv)
    for face in faces:
        body += struct.pack(f"<B{len(face)}iB", len(face), *face, 7)
    body += struct.pack("<4i", 0, 1, 1, 2)
    body += struct.pack("<H3f", 3, 1.0, 2.0, 3.0)
    return header.encode("ascii"), body


def ply_be():
    """Big-endian, double positions, u/v names, uint counts with ushort indices."""
    header = "\n".join([
        "ply",
        "format binary_big_endian 1.0",
        f"element vertex {len(VERTICES)}",
        "property double x",
        "property double y",
        "property double z",
        "property float nx",
        "property float ny",
        "property float nz",
        "property float u",
        "property float v",
        f"element face {len(FACES)}",
        "property list uint ushort vertex_index",
        "end_header",
    ]) + "\r\n"
    body = b""
    for p, n, uv in VERTICES:
        body += struct.pack(">3d3f2f", *p, *n, *uv)
    for face in FACES:
        body += struct.pack(f">I{len(face)}H", len(face), *face)
    return header.encode("ascii") + body


def write_plys():
    write(os.path.join(MESHES, "quad_tri_ascii.ply"), ply_ascii())
    header, body = ply_le()
    write(os.path.join(MESHES, "quad_tri_le.ply"), header + body)
    write(os.path.join(MESHES, "quad_tri_be.ply"), ply_be())
    write(os.path.join(MESHES, "quad_tri.ply.gz"), gzip.compress(header + body, mtime=0))

    # Truncated in the middle of the face data.
    faces_start = len(header) + len(VERTICES) * 9 * 4
    write(os.path.join(BAD, "truncated.ply"), header + body[: faces_start - len(header) + 7])
    # Second face refers to vertex 9 of 5; the bad index sits at this byte offset.
    bad_faces = [[0, 1, 2, 3], [3, 2, 9]]
    header, body = ply_le(bad_faces)
    write(os.path.join(BAD, "bad_index_binary.ply"), header + body)
    offset = faces_start + (1 + 4 * 4 + 1) + 1 + 2 * 4
    print("bad_index_binary.ply: bad index at byte", offset)
    # The same in ascii: the bad face is on line 22.
    write(os.path.join(BAD, "bad_index_ascii.ply"), ply_ascii(bad_faces))
    # Vertex 2 is NaN.
    text = ply_ascii().replace("1 1 0 0 0 1 1 1", "nan 1 0 0 0 1 1 1")
    write(os.path.join(BAD, "nan_vertex.ply"), text)
    # A malformed number on line 18 (vertex 2).
    write(os.path.join(BAD, "bad_number.ply"),
          ply_ascii().replace("1 1 0 0 0 1 1 1", "1 1.2.3 0 0 0 1 1 1"))
    # Claims more faces than the limit allows; must fail before reading or allocating.
    write(os.path.join(BAD, "too_many_faces.ply"),
          ply_ascii().replace(f"element face {len(FACES)}", "element face 100000001"))
    # A gzip stream cut short.
    packed = gzip.compress((header + body) * 50, mtime=0)
    write(os.path.join(BAD, "corrupt.ply.gz"), packed[: len(packed) // 2])


# ------------------------------------------------------------------------------------------------
# glTF

def gltf_buffer():
    chunks = []

    def add(data, align=4):
        offset = sum(len(c) for c in chunks)
        chunks.append(data)
        pad = (-len(data)) % align
        if pad:
            chunks.append(b"\0" * pad)
        return offset, len(data)

    quad = [(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)]
    views = [
        add(b"".join(struct.pack("<3f", *p) for p in quad)),               # 0 positions
        add(b"".join(struct.pack("<3f", 0, 1, 0) for _ in quad)),          # 1 normals
        add(struct.pack("<8f", 0, 0, 1, 0, 1, 1, 0, 1)),                   # 2 uvs
        add(struct.pack("<6H", 0, 2, 1, 0, 3, 2)),                         # 3 uint16 indices
        add(struct.pack("<3B", 0, 1, 2)),                                  # 4 uint8 indices
        add(struct.pack("<3I", 0, 2, 3)),                                  # 5 uint32 indices
        add(struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 0, 1)),                # 6 lamp positions
    ]
    return b"".join(chunks), views


def gltf_document(buffer, views, uri):
    s = math.sqrt(0.5)
    buffer_entry = {"byteLength": len(buffer)}
    if uri is not None:
        buffer_entry["uri"] = uri
    vec3, scalar = "VEC3", "SCALAR"
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": 4, "type": vec3,
         "min": [-1, 0, -1], "max": [1, 0, 1]},
        {"bufferView": 1, "componentType": 5126, "count": 4, "type": vec3},
        {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
        {"bufferView": 3, "componentType": 5123, "count": 6, "type": scalar},
        {"bufferView": 4, "componentType": 5121, "count": 3, "type": scalar},
        {"bufferView": 5, "componentType": 5125, "count": 3, "type": scalar},
        {"bufferView": 6, "componentType": 5126, "count": 3, "type": vec3,
         "min": [0, 0, 0], "max": [1, 0, 1]},
    ]
    return {
        "asset": {"version": "2.0", "generator": "caustica make_test_meshes.py"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_transmission",
                           "KHR_materials_ior", "KHR_materials_emissive_strength"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "Bulb", "type": "point", "color": [1, 0.5, 0.25], "intensity": 100},
            {"name": "Spot", "type": "spot", "intensity": 50,
             "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
            {"name": "Sun", "type": "directional", "intensity": 3},
        ]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 4, 5, 6]}],
        "nodes": [
            {"name": "Root", "scale": [2, 2, 2], "children": [1, 2]},
            {"name": "QuadNode", "mesh": 0, "translation": [0, 1, 0]},
            {"name": "Spinner", "rotation": [0, s, 0, s], "children": [3]},
            {"name": "TriNode", "mesh": 1, "translation": [1, 0, 0]},
            {"name": "PointLight", "translation": [0, 5, 0],
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "SpotLight", "translation": [1, 2, 3], "rotation": [-s, 0, 0, s],
             "extensions": {"KHR_lights_punctual": {"light": 1}}},
            {"name": "SunNode", "matrix": [0, 0, -1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 7, 8, 9, 1],
             "extensions": {"KHR_lights_punctual": {"light": 2}}},
            {"name": "Orphan", "mesh": 0},
        ],
        "meshes": [
            {"name": "Quad", "primitives": [
                {"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3,
                 "material": 0}]},
            {"name": "Tri", "primitives": [
                {"attributes": {"POSITION": 0}, "indices": 4, "material": 1},
                {"attributes": {"POSITION": 0}, "indices": 5, "material": 2},
                {"attributes": {"POSITION": 6}, "material": 3},
                {"attributes": {"POSITION": 0}, "mode": 0},
            ]},
        ],
        "materials": [
            {"name": "Clay", "pbrMetallicRoughness": {
                "baseColorFactor": [0.5, 0.25, 0.125, 1], "metallicFactor": 0,
                "roughnessFactor": 1}},
            {"name": "Chrome", "pbrMetallicRoughness": {
                "baseColorFactor": [0.9, 0.8, 0.7, 1], "metallicFactor": 1,
                "roughnessFactor": 0}},
            {"name": "Glass", "pbrMetallicRoughness": {"metallicFactor": 0, "roughnessFactor": 0},
             "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1},
                            "KHR_materials_ior": {"ior": 1.33}}},
            {"name": "Lamp", "emissiveFactor": [1, 0.5, 0.25],
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}},
        ],
        "buffers": [buffer_entry],
        "bufferViews": [{"buffer": 0, "byteOffset": o, "byteLength": n} for o, n in views],
        "accessors": accessors,
    }


def write_gltf():
    buffer, views = gltf_buffer()
    uri = "data:application/octet-stream;base64," + base64.b64encode(buffer).decode("ascii")
    doc = gltf_document(buffer, views, uri)
    write(os.path.join(MESHES, "lights.gltf"), json.dumps(doc, indent=1) + "\n")

    text = json.dumps(gltf_document(buffer, views, None), separators=(",", ":")).encode()
    text += b" " * ((-len(text)) % 4)
    binary = buffer + b"\0" * ((-len(buffer)) % 4)
    chunks = (struct.pack("<I4s", len(text), b"JSON") + text +
              struct.pack("<I4s", len(binary), b"BIN\0") + binary)
    write(os.path.join(MESHES, "lights.glb"),
          struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks)

    # An accessor that claims more elements than its bufferView holds.
    doc = gltf_document(buffer, views, uri)
    doc["accessors"][0]["count"] = 1000
    write(os.path.join(BAD, "overflowing_accessor.gltf"), json.dumps(doc, indent=1) + "\n")
    # An index beyond the vertex count.
    bad_buffer = bytearray(buffer)
    struct.pack_into("<H", bad_buffer, views[3][0] + 2, 7)
    bad_uri = ("data:application/octet-stream;base64," +
               base64.b64encode(bytes(bad_buffer)).decode("ascii"))
    write(os.path.join(BAD, "bad_index.gltf"),
          json.dumps(gltf_document(bytes(bad_buffer), views, bad_uri), indent=1) + "\n")


# ------------------------------------------------------------------------------------------------
# PLY header variants

def ply_variant_header(fmt):
    """Header lines as MeshLab, Assimp and scanners write them; joined with CRLF."""
    return [
        "ply  ",
        f"format {fmt} 1.0",
        "comment VCGLIB generated",
        "obj_info num_cols 1",
        "",
        "obj_info num_rows 5",
        f"element\tvertex   {len(VERTICES)}",
        "property float32 x",
        "comment between two properties",
        "property float32  y",
        "property float32\tz",
        "property uint8 red",
        "property uint8 green",
        "property uint8 blue",
        "property uint8 alpha",
        "property float32 nx",
        "property float32 ny",
        "property float32 nz",
        "property float32 texture_u",
        "property float32 texture_v",
        "   ",
        "element material 2",
        "property list uint8 float32 ambient",
        "property int16 shininess",
        "comment the faces come after an element that we do not read",
        f"element face {len(FACES)}",
        "property list uint8 int32 vertex_indices",
        "property list uchar float texcoord",
        "property uint16 flags",
        "end_header",
    ]


def write_ply_variants():
    folder = os.path.join(MESHES, "ply_variants")
    os.makedirs(folder, exist_ok=True)
    lines = ply_variant_header("ascii")
    for p, n, uv in VERTICES:
        values = [f"{x:g}" for x in p] + ["200", "100", "50", "255"]
        values += [f"{x:g}" for x in (*n, *uv)]
        lines.append("  ".join(values) + " ")
    lines.append("3 0.1 0.2 0.3 10")
    lines.append("0 0")
    for face in FACES:
        lines.append(" ".join(str(x) for x in [len(face), *face]) + "\t2 0.5 0.5 7")
    write(os.path.join(folder, "extras_ascii.ply"), ("\r\n".join(lines) + "\r\n").encode())

    header = ("\r\n".join(ply_variant_header("binary_little_endian")) + "\r\n").encode()
    body = b""
    for p, n, uv in VERTICES:
        body += struct.pack("<3f4B3f2f", *p, 200, 100, 50, 255, *n, *uv)
    body += struct.pack("<B3fh", 3, 0.1, 0.2, 0.3, 10)
    body += struct.pack("<Bh", 0, 0)
    for face in FACES:
        body += struct.pack(f"<B{len(face)}iB2fH", len(face), *face, 2, 0.5, 0.5, 7)
    write(os.path.join(folder, "extras_le.ply"), header + body)


# ------------------------------------------------------------------------------------------------
# glTF strips, fans, cameras

def embedded(buffer):
    return "data:application/octet-stream;base64," + base64.b64encode(buffer).decode("ascii")


def pack_views(*blobs):
    """One buffer of 4-byte aligned blobs, and a bufferView for each."""
    data, views = b"", []
    for blob in blobs:
        views.append({"buffer": 0, "byteOffset": len(data), "byteLength": len(blob)})
        data += blob + b"\0" * ((-len(blob)) % 4)
    return data, views


# A 2 x 4 grid of vertices in the z = 0 plane: v(2i) = (i, 0, 0), v(2i + 1) = (i, 1, 0).
GRID = [(i, j, 0) for i in range(4) for j in range(2)]
FAN = [(10, 0, 0), (11, 0, 0), (11, 1, 0), (10, 1, 0), (9, 1, 0)]
# Two strip runs over the grid's first and last quads, stitched by repeating 3 and 4; all kept
# triangles face +z.
STRIP_INDICES = [0, 2, 1, 3, 3, 4, 4, 6, 5, 7]
# A fan over FAN with a repeated corner: (0 1 2), (0 2 2) dropped, (0 2 3).
FAN_INDICES = [0, 1, 2, 2, 3]


def strips_fans_document(short_strip=False):
    blob_grid = b"".join(struct.pack("<3f", *p) for p in GRID)
    blob_fan = b"".join(struct.pack("<3f", *p) for p in FAN)
    strip = [0, 2] if short_strip else STRIP_INDICES
    buffer, views = pack_views(blob_grid, blob_fan,
                               struct.pack(f"<{len(strip)}H", *strip),
                               struct.pack(f"<{len(FAN_INDICES)}I", *FAN_INDICES))
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": len(GRID), "type": "VEC3",
         "min": [0, 0, 0], "max": [3, 1, 0]},
        {"bufferView": 1, "componentType": 5126, "count": len(FAN), "type": "VEC3",
         "min": [9, 0, 0], "max": [11, 1, 0]},
        {"bufferView": 2, "componentType": 5123, "count": len(strip), "type": "SCALAR"},
        {"bufferView": 3, "componentType": 5125, "count": len(FAN_INDICES), "type": "SCALAR"},
    ]
    primitives = [
        {"attributes": {"POSITION": 0}, "indices": 2, "mode": 5},  # indexed strip: 4 triangles
        {"attributes": {"POSITION": 0}, "mode": 5},  # non-indexed strip: 6 triangles facing -z
        {"attributes": {"POSITION": 1}, "mode": 6},  # non-indexed fan: 3 triangles
        {"attributes": {"POSITION": 1}, "indices": 3, "mode": 6},  # indexed fan: 2 triangles
        {"attributes": {"POSITION": 0}, "mode": 1},  # lines: skipped
    ]
    if short_strip:
        primitives = primitives[:1]
    return {
        "asset": {"version": "2.0", "generator": "caustica make_test_meshes.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "Strips", "mesh": 0}],
        "meshes": [{"name": "StripsFans", "primitives": primitives}],
        "buffers": [{"byteLength": len(buffer), "uri": embedded(buffer)}],
        "bufferViews": views,
        "accessors": accessors,
    }


def camera_light_document():
    s = math.sqrt(0.5)
    quad = [(-1, 0, -1), (-1, 0, 1), (1, 0, 1), (1, 0, -1)]
    buffer, views = pack_views(b"".join(struct.pack("<3f", *p) for p in quad),
                               struct.pack("<6H", 0, 1, 2, 0, 2, 3))
    return {
        "asset": {"version": "2.0", "generator": "caustica make_test_meshes.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "Spot", "type": "spot", "color": [1, 0.5, 0.25], "intensity": 20,
             "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}},
            {"name": "Sun", "type": "directional", "intensity": 2},
        ]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3, 4]}],
        "nodes": [
            {"name": "Floor", "mesh": 0},
            # Turned 90 degrees about +y: looks down -x.
            {"name": "Eye", "camera": 0, "translation": [1, 2, 10], "rotation": [0, s, 0, s]},
            {"name": "Plan", "camera": 1, "translation": [0, 10, 0]},
            # Turned -90 degrees about +x: shines down -y.
            {"name": "SpotNode", "translation": [0, 4, 0], "rotation": [-s, 0, 0, s],
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "SunNode", "extensions": {"KHR_lights_punctual": {"light": 1}}},
        ],
        "cameras": [
            {"type": "perspective",
             "perspective": {"yfov": 0.6, "aspectRatio": 1.5, "znear": 0.1}},
            {"type": "orthographic",
             "orthographic": {"xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 100}},
        ],
        "meshes": [{"name": "Quad", "primitives": [
            {"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": len(buffer), "uri": embedded(buffer)}],
        "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [-1, 0, -1], "max": [1, 0, 1]},
            {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
    }


# A unit cube around the origin, its triangles wound to face out.
CUBE = [(-.5, -.5, -.5), (.5, -.5, -.5), (.5, .5, -.5), (-.5, .5, -.5),
        (-.5, -.5, .5), (.5, -.5, .5), (.5, .5, .5), (-.5, .5, .5)]
CUBE_INDICES = [0, 3, 2, 0, 2, 1, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                3, 7, 6, 3, 6, 2, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6, 5]
SHEET = [(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)]


def volume_document():
    buffer, views = pack_views(b"".join(struct.pack("<3f", *p) for p in CUBE),
                               struct.pack("<36H", *CUBE_INDICES),
                               b"".join(struct.pack("<3f", *p) for p in SHEET),
                               struct.pack("<6H", 0, 2, 1, 0, 3, 2))
    glass = {"pbrMetallicRoughness": {"metallicFactor": 0, "roughnessFactor": 0}}
    return {
        "asset": {"version": "2.0", "generator": "caustica make_test_meshes.py"},
        "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_volume"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [{"mesh": 0, "name": "tinted cube"},
                  {"mesh": 0, "name": "big tinted cube", "scale": [2, 2, 2],
                   "translation": [3, 0, 0]},
                  {"mesh": 1, "name": "clear cube", "translation": [-3, 0, 0]},
                  {"mesh": 2, "name": "tinted sheet", "translation": [0, -2, 0]}],
        "materials": [
            dict(glass, name="tinted", extensions={
                "KHR_materials_transmission": {"transmissionFactor": 1},
                "KHR_materials_volume": {"attenuationColor": [0.1, 0.5, 0.9],
                                         "attenuationDistance": 2, "thicknessFactor": 1}}),
            dict(glass, name="clear", extensions={
                "KHR_materials_transmission": {"transmissionFactor": 1},
                "KHR_materials_volume": {"thicknessFactor": 1}}),
        ],
        "meshes": [
            {"name": "cube", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1,
                                             "material": 0}]},
            {"name": "clear cube", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1,
                                                   "material": 1}]},
            {"name": "sheet", "primitives": [{"attributes": {"POSITION": 2}, "indices": 3,
                                              "material": 0}]},
        ],
        "buffers": [{"byteLength": len(buffer), "uri": embedded(buffer)}],
        "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
             "min": [-.5, -.5, -.5], "max": [.5, .5, .5]},
            {"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [-1, 0, -1], "max": [1, 0, 1]},
            {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
    }


def write_strips_and_cameras():
    write(os.path.join(MESHES, "strips_fans.gltf"),
          json.dumps(strips_fans_document(), indent=1) + "\n")
    write(os.path.join(BAD, "short_strip.gltf"),
          json.dumps(strips_fans_document(short_strip=True), indent=1) + "\n")
    doc = strips_fans_document(short_strip=True)
    doc["meshes"][0]["primitives"][0]["mode"] = 9
    write(os.path.join(BAD, "unknown_mode.gltf"), json.dumps(doc, indent=1) + "\n")
    write(os.path.join(MESHES, "camera_light.gltf"),
          json.dumps(camera_light_document(), indent=1) + "\n")
    write(os.path.join(MESHES, "volume.gltf"), json.dumps(volume_document(), indent=1) + "\n")


def write_other_bad_files():
    write(os.path.join(BAD, "gltf1_no_asset.gltf"),
          '{\n "meshes": {},\n "programs": {"program_0": {"attributes": ["a_position"], '
          '"fragmentShader": "fs", "vertexShader": "vs"}},\n "shaders": {},\n "techniques": {}\n}\n')
    write(os.path.join(BAD, "garbage.fbx"),
          "This is not an FBX file, only text that a user renamed.\n")
    header = b"binary STL cut short by a failed download".ljust(80, b" ")
    facet = struct.pack("<12fH", 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0)
    write(os.path.join(BAD, "truncated.stl"), header + struct.pack("<I", 1000) + facet)


if __name__ == "__main__":
    os.makedirs(MESHES, exist_ok=True)
    os.makedirs(BAD, exist_ok=True)
    write_plys()
    write_gltf()
    write_ply_variants()
    write_strips_and_cameras()
    write_other_bad_files()
