#!/usr/bin/env python3
"""Positions of a few vertices of the animated sample files at a few times, computed from the
files by this script alone (plain Python: JSON, struct and math), as the reference that
tests/renderer/scene/gltf_animation_test.cc holds the C++ sampler to. It reads LINEAR channels
(rotations by slerp), morph target weights and linear blend skins (JOINTS_0/WEIGHTS_0, the weights
scaled to sum to 1), which is what these files use.

    python3 reference_poses.py   # prints the test's expected values
"""
import json
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
COMPONENTS = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}
FORMATS = {5126: ("f", 4), 5123: ("H", 2), 5121: ("B", 1)}


def load(path):
    with open(path) as f:
        gltf = json.load(f)
    buffers = []
    for b in gltf["buffers"]:
        with open(os.path.join(os.path.dirname(path), b["uri"]), "rb") as f:
            buffers.append(f.read())
    return gltf, buffers


def accessor(gltf, buffers, index):
    a = gltf["accessors"][index]
    view = gltf["bufferViews"][a["bufferView"]]
    n = COMPONENTS[a["type"]]
    fmt, size = FORMATS[a["componentType"]]
    stride = view.get("byteStride", n * size)
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    data = buffers[view["buffer"]]
    return [list(struct.unpack_from("<%d%s" % (n, fmt), data, start + i * stride))
            for i in range(a["count"])]


def matmul(a, b):
    return [[sum(a[r][k] * b[k][c] for k in range(4)) for c in range(4)] for r in range(4)]


def trs(t, r, s):
    x, y, z, w = r
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    rot = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
           [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
           [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    return [[rot[i][0] * s[0], rot[i][1] * s[1], rot[i][2] * s[2], t[i]] for i in range(3)] + \
        [[0, 0, 0, 1]]


def column_major(m):
    return [[m[c * 4 + r] for c in range(4)] for r in range(4)]


def slerp(a, b, s):
    dot = sum(x * y for x, y in zip(a, b))
    if dot < 0:
        b, dot = [-x for x in b], -dot
    if dot > 0.9995:
        return [(1 - s) * x + s * y for x, y in zip(a, b)]
    theta = math.acos(min(dot, 1.0))
    wa, wb = math.sin((1 - s) * theta) / math.sin(theta), math.sin(s * theta) / math.sin(theta)
    return [wa * x + wb * y for x, y in zip(a, b)]


def sample(times, values, t, path):
    if t <= times[0]:
        return values[0]
    if t >= times[-1]:
        return values[-1]
    k = max(i for i in range(len(times)) if times[i] <= t)
    s = (t - times[k]) / (times[k + 1] - times[k])
    if path == "rotation":
        return slerp(values[k], values[k + 1], s)
    return [(1 - s) * x + s * y for x, y in zip(values[k], values[k + 1])]


def pose(gltf, buffers, t):
    nodes = gltf["nodes"]
    local = []
    for n in nodes:
        local.append({"t": n.get("translation", [0, 0, 0]), "r": n.get("rotation", [0, 0, 0, 1]),
                      "s": n.get("scale", [1, 1, 1]), "weights": n.get("weights")})
    for channel in gltf["animations"][0]["channels"]:
        sampler = gltf["animations"][0]["samplers"][channel["sampler"]]
        times = [x[0] for x in accessor(gltf, buffers, sampler["input"])]
        out = accessor(gltf, buffers, sampler["output"])
        node, path = channel["target"]["node"], channel["target"]["path"]
        if path == "weights":
            width = len(out) // len(times)
            out = [[x[0] for x in out[k * width:(k + 1) * width]] for k in range(len(times))]
            local[node]["weights"] = sample(times, out, t, path)
        else:
            local[node][path[0]] = sample(times, out, t, path)
    parent = {c: i for i, n in enumerate(nodes) for c in n.get("children", [])}
    world = {}

    def world_of(i):
        if i not in world:
            n = nodes[i]
            m = column_major(n["matrix"]) if "matrix" in n else trs(
                local[i]["t"], local[i]["r"], local[i]["s"])
            world[i] = matmul(world_of(parent[i]), m) if i in parent else m
        return world[i]

    for i in range(len(nodes)):
        world_of(i)
    return local, world


def apply(m, p):
    return [sum(m[r][c] * p[c] for c in range(3)) + m[r][3] for r in range(3)]


def positions(name, t, vertices):
    gltf, buffers = load(os.path.join(HERE, name))
    local, world = pose(gltf, buffers, t)
    node_index = next(i for i, n in enumerate(gltf["nodes"]) if "mesh" in n)
    node = gltf["nodes"][node_index]
    mesh = gltf["meshes"][node["mesh"]]
    primitive = mesh["primitives"][0]
    base = accessor(gltf, buffers, primitive["attributes"]["POSITION"])
    weights = local[node_index]["weights"] or mesh.get("weights", [])
    for k, target in enumerate(primitive.get("targets", [])):
        moved = accessor(gltf, buffers, target["POSITION"])
        base = [[p[j] + weights[k] * d[j] for j in range(3)] for p, d in zip(base, moved)]
    if "skin" not in node:
        return [apply(world[node_index], base[v]) for v in vertices]
    skin = gltf["skins"][node["skin"]]
    inverse_bind = [column_major(m) for m in
                    accessor(gltf, buffers, skin["inverseBindMatrices"])]
    joints = [matmul(world[j], inverse_bind[k]) for k, j in enumerate(skin["joints"])]
    joint_of = accessor(gltf, buffers, primitive["attributes"]["JOINTS_0"])
    weight_of = accessor(gltf, buffers, primitive["attributes"]["WEIGHTS_0"])
    out = []
    for v in vertices:
        # glTF asks for weights that sum to 1; CesiumMan's do not everywhere, and viewers scale
        # them so (else a vertex shrinks towards the origin).
        weight_sum = sum(weight_of[v])
        total = [0.0, 0.0, 0.0]
        for j, w in zip(joint_of[v], weight_of[v]):
            if w:
                p = apply(joints[j], base[v])
                total = [a + w / weight_sum * b for a, b in zip(total, p)]
        out.append(total)
    return out


CASES = [("SimpleMorph.gltf", 1.5, [0, 1, 2]),
         ("RiggedSimple.gltf", 1.0, [0, 50, 95]),
         ("../../../../../../scenes/cesium-man/CesiumMan.gltf", 0.5, [0, 1000, 3000])]

if __name__ == "__main__":
    for name, t, vertices in CASES:
        for v, p in zip(vertices, positions(name, t, vertices)):
            print("%s t=%g vertex %d: {%.6f, %.6f, %.6f}" % (os.path.basename(name), t, v, *p))
