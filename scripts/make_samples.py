#!/usr/bin/env python3
"""Writes the bundled sample levels in samples/ (glTF with an embedded buffer, and the same
level as OBJ). Run from the repository root: python3 scripts/make_samples.py

The samples are small on purpose: every number in them can be checked by hand, which is what
the tests that read them rely on.
"""
import base64
import json
import struct
from pathlib import Path

OUT = Path(__file__).resolve().parent.parent / "samples"


def quad(a, b, c, d):
    """Two triangles a-b-c, a-c-d (counter-clockwise seen from the front)."""
    return [(a, b, c), (a, c, d)]


def box(x0, y0, z0, x1, y1, z1):
    """Outward-facing closed box (a prop)."""
    p = [(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)]
    # index = xi*4 + yi*2 + zi
    f = []
    f += quad(p[0], p[1], p[3], p[2])  # -x
    f += quad(p[4], p[6], p[7], p[5])  # +x
    f += quad(p[0], p[4], p[5], p[1])  # -y
    f += quad(p[2], p[3], p[7], p[6])  # +y
    f += quad(p[0], p[2], p[6], p[4])  # -z
    f += quad(p[1], p[5], p[7], p[3])  # +z
    return f


H = 3.0          # room height
DOOR = (1.5, 2.5, 2.2)  # z from, z to, height


def room(x0, x1, door_wall_x):
    """Inward-facing floor, ceiling and walls of a 4 x 3 x 4 m room; the wall at
    x == door_wall_x has the door hole."""
    z0, z1 = 0.0, 4.0
    floor = quad((x0, 0, z0), (x0, 0, z1), (x1, 0, z1), (x1, 0, z0))
    ceiling = quad((x0, H, z0), (x1, H, z0), (x1, H, z1), (x0, H, z1))
    walls = []
    walls += quad((x0, 0, z0), (x1, 0, z0), (x1, H, z0), (x0, H, z0))  # z = 0, faces +z
    walls += quad((x0, 0, z1), (x0, H, z1), (x1, H, z1), (x1, 0, z1))  # z = 4, faces -z
    for x, facing_pos in ((x0, True), (x1, False)):
        if x != door_wall_x:
            if facing_pos:
                walls += quad((x, 0, z0), (x, H, z0), (x, H, z1), (x, 0, z1))
            else:
                walls += quad((x, 0, z0), (x, 0, z1), (x, H, z1), (x, H, z0))
            continue
        dz0, dz1, dh = DOOR
        parts = [((z0, dz0), (0, H)), ((dz1, z1), (0, H)), ((dz0, dz1), (dh, H))]
        for (za, zb), (ya, yb) in parts:
            if facing_pos:
                walls += quad((x, ya, za), (x, yb, za), (x, yb, zb), (x, ya, zb))
            else:
                walls += quad((x, ya, za), (x, ya, zb), (x, yb, zb), (x, yb, za))
    return floor, ceiling, walls


def two_rooms():
    kf, kc, kw = room(0.0, 4.0, 4.0)
    lf, lc, lw = room(4.0, 8.0, 4.0)
    dz0, dz1, dh = DOOR
    portal = quad((4.0, 0, dz0), (4.0, dh, dz0), (4.0, dh, dz1), (4.0, 0, dz1))  # faces +x
    table = box(1.0, 0.0, 1.0, 2.0, 0.8, 1.8)
    return {
        "name": "Level",
        "children": [
            {"name": "kitchen-room", "children": [
                {"name": "Floor", "tris": kf, "material": "floor"},
                {"name": "Ceiling", "tris": kc, "material": "wall"},
                {"name": "Walls", "tris": kw, "material": "wall"},
                {"name": "Table-detail", "tris": table, "material": "wood"},
                {"name": "lounge-portal", "tris": portal, "material": "portal"},
            ]},
            {"name": "lounge-room", "children": [
                {"name": "Floor", "tris": lf, "material": "floor"},
                {"name": "Ceiling", "tris": lc, "material": "wall"},
                {"name": "Walls", "tris": lw, "material": "wall"},
            ]},
        ],
    }


def grid_cells(outer, minus=()):
    """Rectangle decomposition of a rectilinear footprint in (x, z): the cells of the grid of
    all its corner coordinates inside `outer` and outside every rectangle of `minus`. A grid
    (rather than fewest rectangles) keeps the mesh conforming: every cell edge meets whole
    edges of its neighbours and of the walls, so the shell closes edge for edge."""
    rects = [outer, *minus]
    xs = sorted({r[k] for r in rects for k in (0, 2)})
    zs = sorted({r[k] for r in rects for k in (1, 3)})

    def inside(x, z, r):
        return r[0] < x < r[2] and r[1] < z < r[3]

    cells = []
    for xa, xb in zip(xs, xs[1:]):
        for za, zb in zip(zs, zs[1:]):
            cx, cz = (xa + xb) / 2, (za + zb) / 2
            if inside(cx, cz, outer) and not any(inside(cx, cz, m) for m in minus):
                cells.append((xa, za, xb, zb))
    return cells


def shell(cells, top=lambda x, z: H):
    """Inward-facing closed shell over a footprint: floor at y = 0 facing up, ceiling at
    y = top(x, z) (a plane) facing down, walls along the footprint boundary facing into the
    room. Returns floor, ceiling, walls triangles."""
    floor, ceiling, walls = [], [], []
    for x0, z0, x1, z1 in cells:
        floor += quad((x0, 0, z0), (x0, 0, z1), (x1, 0, z1), (x1, 0, z0))
        ceiling += quad((x0, top(x0, z0), z0), (x1, top(x1, z0), z0),
                        (x1, top(x1, z1), z1), (x0, top(x0, z1), z1))
    # Boundary: cell edges that no other cell has (reversed); interior is the cell's side.
    edges = []
    for x0, z0, x1, z1 in cells:
        # Counter-clockwise seen from above (+y), so the cell is to the left of each edge.
        loop = [(x0, z0), (x0, z1), (x1, z1), (x1, z0)]
        edges += [(loop[k], loop[(k + 1) % 4]) for k in range(4)]
    eset = set(edges)
    for p, q in edges:
        if (q, p) in eset:
            continue
        (xa, za), (xb, zb) = p, q
        # The wall is the cell edge p -> q raised; its floor edge must run q -> p.
        walls += quad((xb, 0, zb), (xa, 0, za), (xa, top(xa, za), za), (xb, top(xb, zb), zb))
    return floor, ceiling, walls


def room_node(name, floor, ceiling, walls):
    return {"name": name, "children": [
        {"name": "Floor", "tris": floor, "material": "floor"},
        {"name": "Walls", "tris": walls, "material": "wall"},
        {"name": "Ceiling", "tris": ceiling, "material": "wall"},
    ]}


def level(*children):
    return {"name": "Level", "children": list(children)}


def l_room():
    return level(room_node("hall-room", *shell(grid_cells((0, 0, 6, 6), [(3, 3, 6, 6)]))))


def u_room():
    return level(room_node("hall-room", *shell(grid_cells((0, 0, 9, 6), [(3, 3, 6, 6)]))))


def pillar_room():
    return level(room_node("hall-room", *shell(grid_cells((0, 0, 6, 6), [(2.5, 2.5, 3.5, 3.5)]))))


def sloped_hall():
    cells = grid_cells((0, 0, 8, 6))
    return level(room_node("atrium-room", *shell(cells, top=lambda x, z: 6 + x / 4)))


def bound_boxes():
    two = two_rooms()
    building = []
    for _, t in flatten(two):
        # The authored portal quad is a marker, not a surface: merged in, it would close the door.
        if "tris" in t and not t["name"].endswith("-portal"):
            building += t["tris"]
    return level(
        {"name": "building", "tris": building, "material": "wall"},
        {"name": "kitchen-cell", "tris": box(0.0, 0.0, 0.0, 4.0, H, 4.0), "material": "bound"},
        {"name": "lounge-cell", "tris": box(4.0, 0.0, 0.0, 8.0, H, 4.0), "material": "bound"},
    )


def check_shell(tris, volume, what):
    """Closed and consistently oriented (every directed edge once, its reverse once) with the
    given signed volume (divergence theorem: outward shells positive, inward negative)."""
    directed = {}
    for a, b, c in tris:
        for e in ((a, b), (b, c), (c, a)):
            directed[e] = directed.get(e, 0) + 1
    bad = [e for e, n in directed.items() if n != 1 or directed.get((e[1], e[0])) != 1]
    assert not bad, f"{what}: open or inconsistent edges {bad[:4]}"

    def det(a, b, c):
        return (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]))

    v = sum(det(a, b, c) for a, b, c in tris) / 6.0
    assert abs(v - volume) < 1e-9, f"{what}: signed volume {v}, expected {volume}"


def self_check(samples):
    known = {"l_room": 81.0, "u_room": 135.0, "pillar_room": 105.0, "sloped_hall": 336.0}
    for name, tree in samples.items():
        if name in known:
            room = tree["children"][0]
            tris = [t for c in room["children"] for t in c["tris"]]
            check_shell(tris, -known[name], name)
            floor = room["children"][0]["tris"]
            assert all(normal(t)[1] > 0 for t in floor), f"{name}: floor not facing up"
            ceiling = room["children"][2]["tris"]
            assert all(normal(t)[1] < 0 for t in ceiling), f"{name}: ceiling not facing down"
        elif name == "bound_boxes":
            for node in tree["children"][1:]:
                check_shell(node["tris"], 48.0, f"{name}/{node['name']}")


def normal(t):
    a, b, c = t
    u = [b[k] - a[k] for k in range(3)]
    w = [c[k] - a[k] for k in range(3)]
    return (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])


def flatten(tree, prefix=""):
    path = f"{prefix}/{tree['name']}" if prefix else tree["name"]
    yield path, tree
    for c in tree.get("children", []):
        yield from flatten(c, path)


def write_gltf(tree, path):
    materials = []
    nodes, meshes, accessors, views = [], [], [], []
    blob = bytearray()

    def material(name):
        if name not in materials:
            materials.append(name)
        return materials.index(name)

    def add_node(t):
        idx = len(nodes)
        node = {"name": t["name"]}
        nodes.append(node)
        if "tris" in t:
            verts, index = [], {}
            indices = []
            for tri in t["tris"]:
                for v in tri:
                    if v not in index:
                        index[v] = len(verts)
                        verts.append(v)
                    indices.append(index[v])
            pos_off = len(blob)
            for v in verts:
                blob.extend(struct.pack("<3f", *v))
            idx_off = len(blob)
            for i in indices:
                blob.extend(struct.pack("<H", i))
            while len(blob) % 4:
                blob.append(0)
            views.append({"buffer": 0, "byteOffset": pos_off, "byteLength": idx_off - pos_off, "target": 34962})
            views.append({"buffer": 0, "byteOffset": idx_off, "byteLength": 2 * len(indices), "target": 34963})
            mins = [min(v[k] for v in verts) for k in range(3)]
            maxs = [max(v[k] for v in verts) for k in range(3)]
            accessors.append({"bufferView": len(views) - 2, "componentType": 5126, "count": len(verts),
                              "type": "VEC3", "min": mins, "max": maxs})
            accessors.append({"bufferView": len(views) - 1, "componentType": 5123, "count": len(indices),
                              "type": "SCALAR"})
            meshes.append({"name": t["name"], "primitives": [{
                "attributes": {"POSITION": len(accessors) - 2}, "indices": len(accessors) - 1,
                "material": material(t["material"])}]})
            node["mesh"] = len(meshes) - 1
        if t.get("extras"):
            node["extras"] = t["extras"]
        kids = [add_node(c) for c in t.get("children", [])]
        if kids:
            node["children"] = kids
        return idx

    root = add_node(tree)
    doc = {
        "asset": {"version": "2.0", "generator": "portcullis scripts/make_samples.py"},
        "scene": 0,
        "scenes": [{"name": "Scene", "nodes": [root]}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": [{"name": m} for m in materials],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()}],
    }
    path.write_text(json.dumps(doc, indent=1) + "\n")


def write_obj(tree, path):
    lines = [f"# {path.name}: written by scripts/make_samples.py; object names are node paths"]
    count = 0
    for p, t in flatten(tree):
        if "tris" not in t:
            continue
        lines.append(f"o {p}")
        lines.append(f"usemtl {t['material']}")
        index = {}
        faces = []
        for tri in t["tris"]:
            f = []
            for v in tri:
                if v not in index:
                    count += 1
                    index[v] = count
                    lines.append("v %g %g %g" % v)
                f.append(index[v])
            faces.append(f)
        lines += ["f %d %d %d" % tuple(f) for f in faces]
    path.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    OUT.mkdir(exist_ok=True)
    t = two_rooms()
    write_gltf(t, OUT / "two_rooms.gltf")
    write_obj(t, OUT / "two_rooms.obj")
    print("wrote", OUT / "two_rooms.gltf", OUT / "two_rooms.obj")
    samples = {"l_room": l_room(), "u_room": u_room(), "pillar_room": pillar_room(),
               "sloped_hall": sloped_hall(), "bound_boxes": bound_boxes()}
    self_check(samples)
    for name, tree in samples.items():
        write_gltf(tree, OUT / f"{name}.gltf")
        print("wrote", OUT / f"{name}.gltf")
    print("self-check passed: every room shell is closed, inward-facing, with its known volume")
