#!/usr/bin/env python3
"""A brush map written as plain glTF, the way a greybox exporter writes it.

An exporter independent of portcullis (standard library only, it shares no code with the
importer), for tests that judge whether the same brushes read the same as glTF and as .map:

- every world brush (worldspawn, func_group, func_detail*) is a closed convex mesh of its own:
  each plane clipped by the others (f64), the corners written as f32 metres with Y up
  ((x, y, z) -> (x, z, -y) * 0.0254), every face fanned into triangles wound counter-clockwise
  seen from outside, corners per face (no shared vertices across faces);
- all of them are children of one room node `world-room`; func_detail* brushes are named
  `brush_N-detail`;
- brushes with a clip, trigger, hint, origin or liquid (`*`) texture are left out whole, and so
  are brush entities (doors, plats, func_wall and the rest);
- the first info_player_start is a node with extras {"player_start": true}.

Usage: map_to_gltf.py IN.map OUT.gltf [SAME.map]

With SAME.map, also writes what the glTF holds as a brush map (the brushes it kept, as they
were written in IN.map, and the player start), to read the same content both ways.
"""

import base64
import json
import re
import struct
import sys

SCALE = 0.0254
WORLD = ("worldspawn", "func_group")
TOOL = ("clip", "trigger", "hint", "hintskip", "origin")


def parse(text):
    """Entities as (key/values, brushes), a brush a list of (three points, texture) with its
    lines of text at `brush.lines`."""
    ents, depth, cur, brush = [], 0, None, None
    for line in text.splitlines():
        s = line.strip()
        if not s or s.startswith("//"):
            continue
        if s == "{":
            depth += 1
            if depth == 1:
                cur = ({}, [])
            elif depth == 2:
                brush = Brush()
        elif s == "}":
            if depth == 2:
                cur[1].append(brush)
            elif depth == 1:
                ents.append(cur)
            depth -= 1
        elif depth == 1 and s.startswith('"'):
            kv = re.findall(r'"([^"]*)"', s)
            if len(kv) >= 2:
                cur[0][kv[0]] = kv[1]
        elif depth == 2 and s.startswith("("):
            nums = r"([-+\d.eE]+)"
            pts = re.findall(r"\(\s*" + r"\s+".join([nums] * 3) + r"\s*\)", s)
            tex = s.split(")")[3].split()[0] if len(s.split(")")) > 3 else ""
            brush.append(([tuple(map(float, p)) for p in pts[:3]], tex))
            brush.lines.append(s)
    return ents


class Brush(list):
    """A brush's faces, and its text."""

    def __init__(self):
        super().__init__()
        self.lines = []


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def plane(pts):
    """Outward (normal, offset) of a face given by three points, as qbsp reads them."""
    n = cross(sub(pts[0], pts[1]), sub(pts[2], pts[1]))
    ln = dot(n, n) ** 0.5
    n = (n[0] / ln, n[1] / ln, n[2] / ln)
    return n, dot(n, pts[0])


def clip(poly, n, d):
    """The part of a convex polygon behind the plane n.x = d."""
    out = []
    for i, p in enumerate(poly):
        q = poly[(i + 1) % len(poly)]
        dp, dq = dot(n, p) - d, dot(n, q) - d
        if dp <= 0:
            out.append(p)
        if (dp < 0 < dq) or (dq < 0 < dp):
            t = dp / (dp - dq)
            out.append(tuple(p[k] + t * (q[k] - p[k]) for k in range(3)))
    return out


def faces(brush):
    """Each plane's face: a huge square on it clipped by every other plane, counter-clockwise
    seen from outside."""
    planes = [plane(pts) for pts, _ in brush]
    out = []
    for i, (n, d) in enumerate(planes):
        a = (1.0, 0.0, 0.0) if abs(n[0]) < 0.6 else (0.0, 1.0, 0.0)
        u = cross(n, a)
        lu = dot(u, u) ** 0.5
        u = (u[0] / lu, u[1] / lu, u[2] / lu)
        v = cross(n, u)
        c = (n[0] * d, n[1] * d, n[2] * d)
        big = 1 << 20
        poly = [tuple(c[k] + big * (su * u[k] + sv * v[k]) for k in range(3))
                for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        for j, (m, e) in enumerate(planes):
            if j != i and poly:
                poly = clip(poly, m, e)
        if len(poly) >= 3:
            out.append(poly)
    return out


def to_gltf(p):
    return (p[0] * SCALE, p[2] * SCALE, -p[1] * SCALE)


def main(src, dst, same=None):
    ents = parse(open(src, encoding="latin-1").read())
    kept = []
    start_kv = None
    nodes = [{"name": "world-room", "children": []}]
    meshes, accessors, views, blob = [], [], [], bytearray()
    start = None
    count = 0
    for kv, brushes in ents:
        cls = kv.get("classname", "")
        if cls == "info_player_start" and start is None and "origin" in kv:
            o = tuple(float(x) for x in kv["origin"].split())
            start = to_gltf(o)
            start_kv = kv
        if cls not in WORLD and not cls.startswith("func_detail"):
            continue
        for brush in brushes:
            texs = [t.lower() for _, t in brush]
            if any(t.startswith("*") or t in TOOL or t.startswith("trigger") for t in texs):
                continue
            pos, idx = [], []
            for f in faces(brush):
                base = len(pos)
                pos.extend(to_gltf(p) for p in f)
                for k in range(1, len(f) - 1):
                    idx.extend((base, base + k, base + k + 1))
            if len(idx) < 12:
                continue
            kept.append((cls, brush))
            f32 = [struct.unpack("<f", struct.pack("<f", x))[0] for p in pos for x in p]
            lo = [min(f32[k::3]) for k in range(3)]
            hi = [max(f32[k::3]) for k in range(3)]
            pv = len(views)
            views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": 12 * len(pos),
                          "target": 34962})
            blob += struct.pack("<%df" % len(f32), *f32)
            views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": 4 * len(idx),
                          "target": 34963})
            blob += struct.pack("<%dI" % len(idx), *idx)
            accessors.append({"bufferView": pv, "componentType": 5126, "count": len(pos),
                              "type": "VEC3", "min": lo, "max": hi})
            accessors.append({"bufferView": pv + 1, "componentType": 5125, "count": len(idx),
                              "type": "SCALAR"})
            meshes.append({"primitives": [{"attributes": {"POSITION": len(accessors) - 2},
                                           "indices": len(accessors) - 1}]})
            name = "brush_%d" % count + ("-detail" if cls.startswith("func_detail") else "")
            count += 1
            nodes[0]["children"].append(len(nodes))
            nodes.append({"name": name, "mesh": len(meshes) - 1})
    roots = [0]
    if start is not None:
        roots.append(len(nodes))
        nodes.append({"name": "player_start", "translation": list(start),
                      "extras": {"player_start": True}})
    doc = {
        "asset": {"version": "2.0", "generator": "tests/tools/map_to_gltf.py"},
        "scene": 0,
        "scenes": [{"nodes": roots}],
        "nodes": nodes,
        "meshes": meshes,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64,"
                     + base64.b64encode(bytes(blob)).decode()}],
    }
    with open(dst, "w") as out:
        json.dump(doc, out)
    if same:
        text = '{\n"classname" "worldspawn"\n'
        for cls, brush in kept:
            if not cls.startswith("func_detail"):
                text += "{\n" + "\n".join(brush.lines) + "\n}\n"
        text += "}\n"
        for cls, brush in kept:
            if cls.startswith("func_detail"):
                text += '{\n"classname" "func_detail"\n{\n' + "\n".join(brush.lines) + "\n}\n}\n"
        if start_kv is not None:
            text += "{\n" + "".join('"%s" "%s"\n' % kv for kv in start_kv.items()) + "}\n"
        with open(same, "w") as out:
            out.write(text)


if __name__ == "__main__":
    main(*sys.argv[1:4])
