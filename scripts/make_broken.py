#!/usr/bin/env python3
"""Writes samples/broken/: one small level per diagnostic code, each triggering exactly that
code (tests/check.rs asserts it). Run from the repository root after `cargo build`:

    python3 scripts/make_broken.py [path/to/portcullis]

Most levels are the two-room sample with one thing wrong. Levels that need a configuration
are folders (`CODE/level.gltf` + `CODE/portcullis.toml`). Levels about a stored annotation
are converted with portcullis first and the annotation is then edited, as a hand edit or
another tool would. Codes that no level file can trigger (command-line mistakes, output
problems) are listed in samples/broken/README.md instead.
"""
import copy
import json
import math
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import make_samples as ms  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "samples" / "broken"
MALFORMED = ROOT / "tests" / "fixtures" / "malformed"
EXE = sys.argv[1] if len(sys.argv) > 1 else str(ROOT / "target" / "debug" / "portcullis")
H = ms.H


def two_rooms(table=True):
    t = ms.two_rooms()
    if not table:
        kitchen = t["children"][0]
        kitchen["children"] = [c for c in kitchen["children"] if c["name"] != "Table-detail"]
    return t


def child(tree, *path):
    node = tree
    for name in path:
        node = next(c for c in node["children"] if c["name"] == name)
    return node


def closed_room(name, x0, x1, z0=0.0, z1=4.0, holes=()):
    """Inward-facing box room; `holes` are (wall, a0, a1, y0, y1) rectangles cut from walls
    'x0', 'x1' (a = z) or 'z0', 'z1' (a = x)."""
    tris_floor = ms.quad((x0, 0, z0), (x0, 0, z1), (x1, 0, z1), (x1, 0, z0))
    tris_ceiling = ms.quad((x0, H, z0), (x1, H, z0), (x1, H, z1), (x0, H, z1))
    walls = []
    specs = {
        "x0": (lambda a, y: (x0, y, a), (z0, z1), (1, 0, 0)),
        "x1": (lambda a, y: (x1, y, a), (z0, z1), (-1, 0, 0)),
        "z0": (lambda a, y: (a, y, z0), (x0, x1), (0, 0, 1)),
        "z1": (lambda a, y: (a, y, z1), (x0, x1), (0, 0, -1)),
    }
    for wall, (at, (a0, a1), n) in specs.items():
        cut = [h[1:] for h in holes if h[0] == wall]
        us = sorted({a0, a1, *[c for h in cut for c in h[:2]]})
        vs = sorted({0.0, H, *[c for h in cut for c in h[2:]]})
        for ua, ub in zip(us, us[1:]):
            for va, vb in zip(vs, vs[1:]):
                cu, cv = (ua + ub) / 2, (va + vb) / 2
                if any(h[0] < cu < h[1] and h[2] < cv < h[3] for h in cut):
                    continue
                walls += ms.facing(ms.quad(at(ua, va), at(ub, va), at(ub, vb), at(ua, vb)), n)
    return ms.room_node(name, tris_floor, tris_ceiling, walls)


def slatted_rooms(gap=0.005):
    """`kitchen-room` and `lounge-room` sharing the wall x = 4, its middle 2 m cut into 1 cm
    slats with `gap`-wide slits floor to ceiling: under the crack width the slits are closed
    (no portal), and `check --sightlines` reports the rays through them as
    SIGHTLINES_THROUGH_CRACKS (gen_diagnostics_doc.py's example)."""
    holes, z = [], 1.0
    while z + gap + 0.01 < 3.0:
        holes.append((z, z + gap, 0.0, H))
        z += gap + 0.01
    return ms.level(closed_room("kitchen-room", 0.0, 4.0, holes=[("x1", *h) for h in holes]),
                    closed_room("lounge-room", 4.0, 8.0, holes=[("x0", *h) for h in holes]))


def door_quad(x, nx, z0=1.5, z1=2.5, h=2.2):
    return ms.wall_x(x, [ms.rect_zy(z0, 0, z1, h)], nx)


def write(tree, name, post=None):
    path = OUT / name
    path.parent.mkdir(parents=True, exist_ok=True)
    ms.write_gltf(tree, path)
    if post:
        doc = json.loads(path.read_text())
        post(doc)
        path.write_text(json.dumps(doc, indent=1) + "\n")
    return path


def node_index(doc, name):
    return next(i for i, n in enumerate(doc["nodes"]) if n.get("name") == name)


def converted(tree, edit):
    """The level annotated by portcullis, with `edit(doc, ext)` applied to the glTF JSON."""
    with tempfile.TemporaryDirectory() as d:
        raw = Path(d) / "raw.gltf"
        ms.write_gltf(tree, raw)
        out = Path(d) / "out.gltf"
        subprocess.run([EXE, "convert", str(raw), "-o", str(out), "--color", "never"],
                       check=True, capture_output=True)
        doc = json.loads(out.read_text())
        # A .gltf output keeps its buffer next to it; embed it so the sample is one file.
        import base64
        for b in doc.get("buffers", []):
            uri = b.get("uri", "")
            if uri and not uri.startswith("data:"):
                data = (Path(d) / uri).read_bytes()
                b["uri"] = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
        edit(doc, doc["extensions"]["PORTCULLIS_portals"])
        return doc


def write_doc(doc, name):
    path = OUT / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(doc, indent=1) + "\n")


def mat_mul(a, b):
    """4x4 column-major (glTF order) product a * b."""
    at = lambda m, r, c: m[c * 4 + r]  # noqa: E731
    return [sum(at(a, r, k) * at(b, k, c) for k in range(4)) for c in range(4) for r in range(4)]


def transform_point(m, p):
    return [sum(m[c * 4 + r] * (list(p) + [1.0])[c] for c in range(4)) for r in range(3)]


def teleporter_portals(ext):
    return [i for i, p in enumerate(ext["portals"]) if p.get("kind") == "teleporter"]


# --- the levels -------------------------------------------------------------------------------

def level_samples():
    s = {}

    # Input read, with problems.
    def nan_triangle(doc):
        # The lamp's second triangle gets a NaN coordinate (JSON cannot hold NaN; the buffer can).
        pass
    t = two_rooms()
    child(t, "kitchen-room")["children"].append({
        "name": "Lamp-detail", "material": "wood",
        "tris": [((1.0, 0.0, 3.0), (1.5, 0.0, 3.0), (1.0, 1.0, 3.0)),
                 ((1.0, 0.0, 3.5), (1.5, 0.0, 3.5), (1.0, 1.0, float("nan")))]})
    s["GEOM_NON_FINITE.gltf"] = (t, fix_nan_bounds)

    t = two_rooms()
    # A triangle that repeats a vertex (exporters leave these behind).
    child(t, "kitchen-room", "Floor")["tris"].append(((0.5, 0, 0.5), (0.5, 0, 0.5), (1.0, 0, 1.0)))
    s["GEOM_DEGENERATE_TRIANGLES.gltf"] = (t, None)

    def lines(doc):
        prim = doc["meshes"][0]["primitives"][0]
        doc["meshes"][0]["primitives"].append({"attributes": dict(prim["attributes"]), "mode": 1})
    s["GLTF_NON_TRIANGLES_SKIPPED.gltf"] = (two_rooms(), lines)

    def no_scene(doc):
        del doc["scene"]
        del doc["scenes"]
    s["GLTF_NO_SCENE.gltf"] = (two_rooms(), no_scene)

    t = two_rooms()
    t["children"].append({"name": "Marker", "children": [{"name": "Inner"}]})

    def overflow(doc):
        # Each scale is finite; their product is not.
        for name in ("Marker", "Inner"):
            doc["nodes"][node_index(doc, name)]["scale"] = [1e200, 1e200, 1e200]
    s["GLTF_TRANSFORM_INVALID.gltf"] = (t, overflow)

    def instancing(doc):
        table = doc["nodes"][node_index(doc, "Table-detail")]
        pos = doc["meshes"][table["mesh"]]["primitives"][0]["attributes"]["POSITION"]
        table["extensions"] = {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": pos}}}
        doc["extensionsUsed"] = ["EXT_mesh_gpu_instancing"]
    s["GLTF_EXTENSION_IGNORED.gltf"] = (two_rooms(), instancing)

    t = {"name": "Level", "children": [{"name": "Marker"}]}
    s["EMPTY_SCENE.gltf"] = (t, None)

    # Tags.
    t = two_rooms()
    t["children"].append({"name": "hall_room"})
    s["TAG_NEAR_MISS.gltf"] = (t, None)

    t = two_rooms()
    child(t, "kitchen-room", "lounge-portal")["name"] = "cellar-portal"
    s["TAG_UNKNOWN_TARGET.gltf"] = (t, None)

    t = two_rooms()
    # A second node with the kitchen's name, holding a crate inside the kitchen.
    t["children"].append({"name": "kitchen-room", "children": [
        {"name": "Crate", "tris": ms.box(2.5, 0, 2.5, 3.0, 0.5, 3.0), "material": "wood"}]})
    s["TAG_DUPLICATE_ROOM.gltf"] = (t, None)

    t = two_rooms()
    kitchen = child(t, "kitchen-room")
    p = child(t, "kitchen-room", "lounge-portal")
    kitchen["children"].remove(p)
    t["children"].append(p)
    s["TAG_PORTAL_NO_SOURCE.gltf"] = (t, None)

    t = two_rooms()
    del child(t, "kitchen-room", "lounge-portal")["tris"]
    s["TAG_PORTAL_NO_MESH.gltf"] = (t, None)

    t = two_rooms()
    t["children"].append({"name": "Volume", "tris": ms.box(20, 0, 0, 24, 3, 4), "material": "bound",
                          "extras": {"bound": True}})
    s["TAG_BOUND_NO_ROOM.gltf"] = (t, None)

    t = two_rooms()
    child(t, "kitchen-room")["children"].append({"name": "Volume", "extras": {"bound": True}})
    s["TAG_BOUND_NO_MESH.gltf"] = (t, None)

    t = two_rooms()
    child(t, "kitchen-room")["children"].append({"name": "Spawn", "extras": {"player_start": [1]}})
    s["TAG_EXTRAS_INVALID.gltf"] = (t, None)

    t = ms.teleporter()
    child(t, "a-room", "tp_a")["extras"]["teleport_exit"] = "tp_nowhere"
    s["TAG_TELEPORT_EXIT_UNKNOWN.gltf"] = (t, None)

    t = {"name": "Level", "children": [{"name": "Box", "tris": ms.box(0, 0, 0, 1, 1, 1), "material": "wood"}]}
    s["TAG_NO_ROOMS.gltf"] = (t, None)

    # Two Doom-style sectors (one mesh node each, `sector_N` with extras `doom_sector`), checked
    # with the default rules: nothing is a room, and the report names `--tags doom`.
    def sector(n, x0, x1, holes):
        room = closed_room(f"sector_{n}", x0, x1, holes=holes)
        tris = [tri for c in room["children"] for tri in c["tris"]]
        return {"name": f"sector_{n}", "tris": tris, "material": "wall",
                "extras": {"doom_sector": n, "floor_height": 0, "ceiling_height": 96}}
    door = (1.5, 2.5, 0.0, 2.2)
    t = {"name": "E1M1", "children": [sector(0, 0, 4, [("x1", *door)]), sector(1, 4, 8, [("x0", *door)])]}
    s["TAGS_PRESET_SUGGESTED.gltf"] = (t, None)

    # Cells.
    # Stored 2e5 m out (f32 there is good to about 16 mm): a node translation would not do,
    # since the tolerance comes from the stored coordinates, not from where nodes put them.
    def shifted(node, dx):
        node = dict(node)
        if "tris" in node:
            node["tris"] = [[(v[0] + dx, v[1], v[2]) for v in tr] for tr in node["tris"]]
        if "children" in node:
            node["children"] = [shifted(c, dx) for c in node["children"]]
        return node
    s["TOLERANCE_CAPPED.gltf"] = (shifted(two_rooms(), 200000.0), None)

    shell = closed_room("x", 0.0, 4.0)
    floor, ceiling, walls = (child(shell, n)["tris"] for n in ("Floor", "Ceiling", "Walls"))
    t = {"name": "Level", "children": [
        {"name": "hall-room", "children": [{"name": "Floor", "tris": floor, "material": "floor"}]},
        {"name": "Shell", "children": [{"name": "Walls", "tris": walls, "material": "wall"},
                                       {"name": "Ceiling", "tris": ceiling, "material": "wall"}]}]}
    s["CELL_ROOM_FROM_FLOOR.gltf"] = (t, None)

    # A closed door: a floor walled by walls of no height (each edge a zero-area quad, its
    # corners distinct vertices, as a Doom sector whose floor and ceiling meet is written),
    # lying on the kitchen's floor, which renders it.
    door = [(1.0, 0.0, 1.0), (1.0, 0.0, 2.0), (2.0, 0.0, 2.0), (2.0, 0.0, 1.0)]
    flat = []
    for k in range(4):
        a, b = door[k], door[(k + 1) % 4]
        flat += [(a, b, b), (a, b, a)]
    t = two_rooms()
    t["children"].append({"name": "door-room", "children": [
        {"name": "Floor", "tris": ms.facing(ms.quad(*door), (0, 1, 0)) + flat,
         "material": "floor", "unshared": True}]})
    s["CELL_ROOM_ZERO_HEIGHT.gltf"] = (t, None)

    # Two rooms through a doorway, the kitchen's back wall slit floor to ceiling 5 mm wide:
    # under the 8 mm crack width, the slit is closed (no opening to the exterior) and said so.
    s["CRACKS_CLOSED.gltf"] = (ms.level(
        closed_room("kitchen-room", 0.0, 4.0, holes=[("x1", 1.5, 2.5, 0, 2.2), ("x0", 2.0, 2.005, 0, H)]),
        closed_room("lounge-room", 4.0, 8.0, holes=[("x0", 1.5, 2.5, 0, 2.2)])), None)

    t = two_rooms()
    t["children"].append({"name": "cellar-room"})
    s["CELL_ROOM_EMPTY.gltf"] = (t, None)

    t = two_rooms()
    t["children"].append({"name": "shelf-room", "children": [
        {"name": "Board", "tris": ms.wall_x(20.0, [ms.rect_zy(0, 0, 1, 1)], 1), "material": "wood"}]})
    s["CELL_ROOM_DEGENERATE.gltf"] = (t, None)

    bb = ms.bound_boxes()
    kitchen_cell = child(bb, "kitchen-cell")
    # Dent the top of the kitchen's bound: a pyramid pushed down into it, so it is not convex.
    tris = [tr for tr in kitchen_cell["tris"] if not all(v[1] == H for v in tr)]
    c = (2.0, H - 0.5, 2.0)
    top = [(0.0, H, 0.0), (4.0, H, 0.0), (4.0, H, 4.0), (0.0, H, 4.0)]
    for k in range(4):
        a, b = top[k], top[(k + 1) % 4]
        tris += ms.facing([(a, b, c)], (0, 1, 0))
    kitchen_cell["tris"] = tris
    s["CELL_BOUND_NOT_CONVEX.gltf"] = (bb, None)

    n = 40
    ring = [(2 + 2 * math.cos(2 * math.pi * k / n), 2 + 2 * math.sin(2 * math.pi * k / n)) for k in range(n)]
    floor = ms.facing(ms.fan([(x, 0.0, z) for x, z in ring]), (0, 1, 0))
    ceiling = ms.facing(ms.fan([(x, H, z) for x, z in ring]), (0, -1, 0))
    walls = []
    for k in range(n):
        (xa, za), (xb, zb) = ring[k], ring[(k + 1) % n]
        inward = (2 - (xa + xb) / 2, 0, 2 - (za + zb) / 2)
        walls += ms.facing(ms.quad((xa, 0, za), (xb, 0, zb), (xb, H, zb), (xa, H, za)), inward)
    s["CELL_TOO_MANY_PLANES.gltf"] = (ms.level(ms.room_node("tower-room", floor, ceiling, walls)), None)

    t = ms.level(closed_room("kitchen-room", 0.0, 4.0), closed_room("lounge-room", 3.0, 7.0))
    s["CELL_OVERLAP/level.gltf"] = (t, None)

    t = two_rooms()
    t["children"].append({"name": "Crate", "tris": ms.box(20, 0, 0, 21, 1, 1), "material": "wood"})
    s["CELL_GEOMETRY_OUTSIDE.gltf"] = (t, None)

    # Authored portals.
    t = two_rooms()
    child(t, "kitchen-room", "lounge-portal")["tris"] = door_quad(0.0, -1)
    s["PORTAL_AUTHORED_UNMATCHED.gltf"] = (t, None)

    t = two_rooms()
    child(t, "kitchen-room", "lounge-portal")["tris"] = door_quad(4.0, -1)
    s["PORTAL_AUTHORED_WRONG_WAY.gltf"] = (t, None)

    hall = closed_room("hall-room", 0.0, 8.0, 4.0, 8.0,
                       holes=[("z0", 1.5, 2.5, 0, 2.2), ("z0", 5.5, 6.5, 0, 2.2)])
    hall["children"].append({"name": "Doors", "material": "portal", "extras": {"portal": True},
                             "tris": ms.facing(ms.quad((1.0, 0, 4.0), (7.0, 0, 4.0), (7.0, 2.2, 4.0),
                                                       (1.0, 2.2, 4.0)), (0, 0, -1))})
    t = ms.level(closed_room("kitchen-room", 0.0, 4.0, holes=[("z1", 1.5, 2.5, 0, 2.2)]),
                 closed_room("lounge-room", 4.0, 8.0, holes=[("z1", 5.5, 6.5, 0, 2.2)]), hall)
    s["PORTAL_AUTHORED_AMBIGUOUS.gltf"] = (t, None)

    t = two_rooms()
    q = child(t, "kitchen-room", "lounge-portal")
    q["tris"] = [tuple((x + 0.05, y, z) if (y, z) == (2.2, 2.5) else (x, y, z) for x, y, z in tr)
                 for tr in q["tris"]]
    s["PORTAL_NOT_PLANAR.gltf"] = (t, None)

    t = two_rooms()
    child(t, "kitchen-room", "lounge-portal")["tris"] = [((4.0, 0.0, 2.0), (4.0, 2.2, 2.0), (4.0, 1.1, 2.0000005))]
    s["PORTAL_TOO_FEW_POINTS.gltf"] = (t, None)

    t = two_rooms()
    # An L: the door rectangle without its top-right quarter.
    child(t, "kitchen-room", "lounge-portal")["tris"] = ms.wall_x(
        4.0, [ms.rect_zy(1.5, 0, 2.5, 1.1), ms.rect_zy(1.5, 1.1, 2.0, 2.2)], 1)
    s["PORTAL_NOT_CONVEX.gltf"] = (t, None)

    t = ms.level(ms.room_node("hall-room", *ms.box_room(0.0, 4.0)))
    child(t, "hall-room")["children"].append({
        "name": "Mirror", "tris": ms.wall_x(2.0, [ms.rect_zy(1.0, 0.5, 3.0, 2.5)], 1), "material": "portal",
        "extras": {"portal": True, "portal_kind": "mirror"}})
    s["PORTAL_NOT_ON_BOUNDARY.gltf"] = (t, None)

    t = two_rooms()
    child(t, "kitchen-room", "lounge-portal")["tris"] = door_quad(2.0, 1)
    s["PORTAL_SEPARATES_NOTHING.gltf"] = (t, None)

    t = two_rooms()
    child(t, "kitchen-room")["children"].append(
        {"name": "Door", "tris": door_quad(4.0, 1), "material": "portal", "extras": {"portal": "lounge"}})
    s["PORTAL_DUPLICATE.gltf"] = (t, None)

    t = ms.teleporter()
    child(t, "b-room", "tp_b")["tris"] = ms.wall_x(10.0, [ms.rect_zy(0.5, 0.0, 3.5, 2.0)], 1)
    s["TRANSFORM_EXIT_MISMATCH.gltf"] = (t, None)

    # The cell graph.
    s["GRAPH_UNREACHABLE.gltf"] = (ms.level(closed_room("kitchen-room", 0.0, 4.0),
                                            closed_room("lounge-room", 4.0, 8.0)), None)

    t = two_rooms()
    child(t, "kitchen-room", "lounge-portal")["extras"] = {"one_way": True}
    s["GRAPH_ONE_WAY_DEAD_END.gltf"] = (t, None)

    t = ms.level(ms.room_node("hall-room", *ms.box_room(0.0, 4.0)))
    for name, x, nx in (("MirrorWest", 0.0, 1), ("MirrorEast", 4.0, -1)):
        child(t, "hall-room")["children"].append({
            "name": name, "tris": ms.wall_x(x, [ms.rect_zy(1.0, 0.5, 3.0, 2.5)], nx), "material": "portal",
            "extras": {"portal": True, "portal_kind": "mirror"}})
    s["GRAPH_TRANSFORM_LOOP.gltf"] = (t, None)

    t = two_rooms()
    t["children"].append({"name": "Spawn", "extras": {"player_start": True}})
    s["PLAYER_START_OUTSIDE.gltf"] = (t, lambda doc: doc["nodes"][node_index(doc, "Spawn")]
                                      .update({"translation": [20.0, 1.0, 2.0]}))

    # Rooms of solid blocks: a closet of slabs, a hollow box of six slabs standing in it.
    def closet(*extra, hollow=True):
        box = [ms.block(f"box_{k}", b) for k, b in enumerate([
            (0.6, 0.0, 0.6, 1.4, 0.1, 1.4), (0.6, 0.7, 0.6, 1.4, 0.8, 1.4),
            (0.6, 0.1, 0.6, 0.7, 0.7, 1.4), (1.3, 0.1, 0.6, 1.4, 0.7, 1.4),
            (0.7, 0.1, 0.6, 1.3, 0.7, 0.7), (0.7, 0.1, 1.3, 1.3, 0.7, 1.4)])]
        return ms.level(ms.slab_room("closet-room", 0, 2, 0, 2, 2.5, 0.3,
                                     extra=box if hollow else ()), *extra)
    torch = lambda at: {"name": "Torch", "extras": {"occupant": True}, "translation": at}  # noqa: E731
    s["CELL_POCKETS_FILLED.gltf"] = (closet(ms.start((1.7, 1.0, 1.7))), None)
    s["CELL_ROOM_NO_OCCUPANT/level.gltf"] = (closet(), None)
    s["CELL_OCCUPANT_IN_SOLID.gltf"] = (
        closet(ms.start((1.0, 1.0, 1.0)), torch((2.15, 1.5, 1.0)), hollow=False), None)
    s["OCCUPANT_OUTSIDE.gltf"] = (
        closet(ms.start((1.0, 1.0, 1.0)), torch((5.0, 1.5, 1.0)), hollow=False), None)
    # A crate block missing one triangle of its top: read as a surface, not as a block.
    crate = ms.block("crate", (0.6, 0.0, 0.6, 1.0, 0.4, 1.0))
    crate["tris"] = crate["tris"][:7] + crate["tris"][8:]
    s["CELL_BLOCK_OPEN.gltf"] = (ms.level(ms.slab_room("closet-room", 0, 2, 0, 2, 2.5, 0.3, extra=[crate]),
                                          ms.start((1.5, 1.0, 1.5))), None)

    # Leaks: a window in the kitchen's outer wall.
    def windowed():
        t = ms.level(closed_room("kitchen-room", 0.0, 4.0, holes=[("x1", 1.5, 2.5, 0, 2.2), ("z0", 1.0, 3.0, 1.0, 2.0)]),
                     closed_room("lounge-room", 4.0, 8.0, holes=[("x0", 1.5, 2.5, 0, 2.2)]))
        t["children"].append({"name": "Spawn", "extras": {"player_start": True}})
        return t
    spawn = lambda doc: doc["nodes"][node_index(doc, "Spawn")].update({"translation": [6.0, 1.0, 2.0]})  # noqa: E731
    s["EXTERIOR_OPENINGS.gltf"] = (windowed(), spawn)
    s["LEAK/level.gltf"] = (windowed(), spawn)
    return s


def fix_nan_bounds(doc):
    for a in doc["accessors"]:
        for k in ("min", "max"):
            if k in a:
                a[k] = [0.0 if (v != v) else v for v in a[k]]


def annotated_samples():
    s = {}

    def bad_cell(doc, ext):
        ext["portals"][0]["cells"] = [0, 7]
    s["ANNOTATION_INVALID.gltf"] = converted(two_rooms(), bad_cell)

    def moved(doc, ext):
        doc["nodes"][node_index(doc, "Table-detail")]["translation"] = [0.1, 0.0, 0.0]
    s["ANNOTATION_STALE.gltf"] = converted(two_rooms(), moved)

    def unpaired(doc, ext):
        for p in ext["portals"]:
            p.pop("partner", None)
    s["PORTAL_UNPAIRED.gltf"] = converted(two_rooms(), unpaired)

    def shifted(doc, ext):
        p = ext["portals"][1]
        p["polygon"] = [[x, y, z + 0.3] for x, y, z in p["polygon"]]
    s["PORTAL_PARTNER_MISMATCH.gltf"] = converted(two_rooms(), shifted)

    def scaled(doc, ext):
        i, j = teleporter_portals(ext)
        pi, pj = ext["portals"][i], ext["portals"][j]
        exit_centre = [sum(v[k] for v in pj["polygon"]) / len(pj["polygon"]) for k in range(3)]
        # Twice as large about the exit's centre, and the exit polygon grown to match.
        to = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, *exit_centre, 1]
        back = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, *[-c for c in exit_centre], 1]
        grow = [2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1]
        m = mat_mul(to, mat_mul(grow, mat_mul(back, pi["transform"])))
        shrink = [0.5, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, 1]
        pi["transform"] = m
        pj["transform"] = mat_mul(pj["transform"], mat_mul(to, mat_mul(shrink, back)))
        image = [transform_point(m, v) for v in pi["polygon"]]
        pj["polygon"] = list(reversed(image))
    s["TRANSFORM_NOT_RIGID.gltf"] = converted(ms.teleporter(), scaled)

    def not_inverse(doc, ext):
        i, j = teleporter_portals(ext)
        ext["portals"][j]["transform"][13] += 1.0
    s["TRANSFORM_PARTNER_NOT_INVERSE.gltf"] = converted(ms.teleporter(), not_inverse)

    def tilted(doc, ext):
        p = next(p for p in ext["portals"] if p.get("kind") == "mirror")
        # The reflection plane moved 25 cm behind the mirror (x = 3.75 instead of 4).
        p["transform"][12] -= 0.5
    s["TRANSFORM_MIRROR_PLANE.gltf"] = converted(ms.mirror(), tilted)
    return s


def copies():
    """Files that cannot be read at all: the malformed fixtures, and a few written here."""
    c = {
        "GLB_INVALID.glb": MALFORMED / "gltf" / "truncated.glb",
        "GLTF_INVALID_JSON.gltf": MALFORMED / "gltf" / "invalid_json.gltf",
        "GLTF_UNSUPPORTED_VERSION.gltf": MALFORMED / "gltf" / "wrong_version.gltf",
        "GLTF_BUFFER_MISSING.gltf": MALFORMED / "gltf" / "missing_bin.gltf",
        "GLTF_ACCESSOR_OUT_OF_BOUNDS.gltf": MALFORMED / "gltf" / "accessor_oob.gltf",
        "GLTF_NODE_CYCLE.gltf": MALFORMED / "gltf" / "node_cycle.gltf",
        "MESH_INDEX_OUT_OF_RANGE.gltf": MALFORMED / "gltf" / "index_out_of_range.gltf",
        "OBJ_NOT_TEXT.obj": MALFORMED / "obj" / "binary.obj",
        "OBJ_BAD_STATEMENT.obj": MALFORMED / "obj" / "bad_number.obj",
        "OBJ_BAD_INDEX.obj": MALFORMED / "obj" / "bad_index.obj",
    }
    for name, src in c.items():
        shutil.copyfile(src, OUT / name)


def written():
    (OUT / "INPUT_EMPTY.gltf").write_bytes(b"")
    (OUT / "INPUT_FORMAT_UNKNOWN.fbx").write_text("; an FBX ASCII file portcullis does not read\n")
    d = OUT / "IO_READ_FAILED.gltf"
    d.mkdir(exist_ok=True)
    (d / "README.md").write_text("A folder named like a level: reading it fails (IO_READ_FAILED).\n")
    (OUT / "USD_UNSUPPORTED_BUILD.usda").write_text(USDA)
    for code, text in USD_SAMPLES.items():
        (OUT / f"{code}.usda").write_text(text)
    base = two_rooms()

    def required(doc):
        doc["extensionsUsed"] = ["KHR_draco_mesh_compression"]
        doc["extensionsRequired"] = ["KHR_draco_mesh_compression"]
    write(base, "GLTF_REQUIRED_EXTENSION_UNSUPPORTED.gltf", required)
    write(base, "GLTF_BUFFER_TOO_SHORT.gltf", lambda doc: doc["buffers"][0].update(
        {"byteLength": doc["buffers"][0]["byteLength"] + 64}))
    write(base, "GLTF_BAD_INDEX.gltf", lambda doc: doc["nodes"][node_index(doc, "Floor")].update({"mesh": 99}))

    def vec2(doc):
        pos = doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
        doc["accessors"][pos]["type"] = "VEC2"
        doc["accessors"][pos]["min"] = doc["accessors"][pos]["min"][:2]
        doc["accessors"][pos]["max"] = doc["accessors"][pos]["max"][:2]
    write(base, "GLTF_ACCESSOR_INVALID.gltf", vec2)

    obj = OUT / "OBJ_MTL_MISSING.obj"
    ms.write_obj(base, obj)
    obj.write_text("mtllib missing.mtl\n" + obj.read_text())
    obj = OUT / "OBJ_UNSUPPORTED_STATEMENT.obj"
    ms.write_obj(base, obj)
    obj.write_text(obj.read_text() + "l 1 2\n")
    obj = OUT / "OBJ_POLYGON_SELF_INTERSECTING.obj"
    ms.write_obj(base, obj)
    text = obj.read_text()
    n = sum(1 for line in text.splitlines() if line.startswith("v "))
    obj.write_text(text + "o Level/kitchen-room/Rug-detail\n"
                   "v 1 0.01 1\nv 2 0.01 2\nv 2 0.01 1\nv 1 0.01 2\n"
                   f"f {n + 1} {n + 2} {n + 3} {n + 4}\n")

    (OUT / "CONFIG_INVALID").mkdir(exist_ok=True)
    write(base, "CONFIG_INVALID/level.gltf")
    (OUT / "CONFIG_INVALID" / "portcullis.toml").write_text("[cells]\nmax_plane = 12  # a typo of max_planes\n")
    (OUT / "TAGS_RULE_INVALID").mkdir(exist_ok=True)
    write(base, "TAGS_RULE_INVALID/level.gltf")
    (OUT / "TAGS_RULE_INVALID" / "portcullis.toml").write_text(
        "[[tags.rule]]\nid = \"mine.room\"\nkind = \"room\"\npattern = '^(?P<name>.+-zone$'\n")
    (OUT / "CELL_OVERLAP").mkdir(exist_ok=True)
    (OUT / "CELL_OVERLAP" / "portcullis.toml").write_text(
        "# The two rooms overlap and share no opening; only the overlap is under test here.\n"
        "[check]\nignore = [\"GRAPH_UNREACHABLE\"]\n")
    (OUT / "CELL_ROOM_NO_OCCUPANT").mkdir(exist_ok=True)
    (OUT / "CELL_ROOM_NO_OCCUPANT" / "portcullis.toml").write_text(
        "# The box's inside is a region no portal reaches; only the room's doubt is under test.\n"
        "[check]\nignore = [\"GRAPH_UNREACHABLE\"]\n")
    (OUT / "LEAK").mkdir(exist_ok=True)
    (OUT / "LEAK" / "portcullis.toml").write_text("[check]\nsealed = true\n")


def usda(extra="", meta='upAxis = "Y"\n    metersPerUnit = 1', mesh_extra="", indices=None):
    """A closed 4 x 3 x 4 m room `room_hall` as USD text, with `extra` prims under /Level."""
    idx = indices or "[0, 1, 3, 2, 4, 6, 7, 5, 0, 4, 5, 1, 2, 3, 7, 6, 0, 2, 6, 4, 1, 5, 7, 3]"
    return f"""#usda 1.0
(
    {meta}
)

def Xform "Level"
{{
    def Mesh "room_hall"
    {{
        int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
        int[] faceVertexIndices = {idx}
        point3f[] points = [(0, 0, 0), (0, 0, 4), (0, 3, 0), (0, 3, 4), (4, 0, 0), (4, 0, 4), (4, 3, 0), (4, 3, 4)]
{mesh_extra}    }}
{extra}}}
"""


# A prop inside the room, as its own mesh prim (the room is the mesh `room_hall`; the prop is a
# detail so it never shapes the room).
def usd_prop(name, body):
    return f"""    def Mesh "{name}"
    {{
{body}    }}
"""


USD_SAMPLES = {
    # Not a stage at all: a syntax error on line 1.
    "USD_OPEN_FAILED": "#usda 1.0\n(\n    upAxis = \"Y\"\n\ndef Xform \"Level\" {\n",
    # An index past the last point.
    "USD_MESH_INVALID": usda(extra=usd_prop("Crate", """        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 9]
        point3f[] points = [(1, 0, 1), (2, 0, 1), (1, 1, 1)]
""")),
    # A bow tie face.
    "USD_POLYGON_NOT_SIMPLE": usda(extra=usd_prop("Rug", """        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(1, 0.01, 1), (2, 0.01, 2), (2, 0.01, 1), (1, 0.01, 2)]
""")),
    # No stage metadata: Y up and centimetres are USD's fallbacks.
    "USD_UNITS_ASSUMED": usda(meta='doc = "no upAxis, no metersPerUnit"'),
    "USD_PRIMS_HIDDEN": usda(extra=usd_prop("Ghost", """        token visibility = "invisible"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(1, 0, 1), (2, 0, 1), (1, 1, 1)]
""")),
    "USD_GPRIM_UNSUPPORTED": usda(extra="""    def Cube "Crate"
    {
        double size = 0.5
        double3 xformOp:translate = (2, 0.25, 2)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
"""),
    "USD_PORTAL_LIGHT_IGNORED": usda(extra="""    def PortalLight "portal_window"
    {
    }
"""),
    "USD_COMPOSITION_ERROR": usda(extra="""    def Xform "Shelf" (
        prepend references = @./no_such_file.usda@
    )
    {
    }
"""),
}


USDA = """#usda 1.0
(
    upAxis = "Y"
    metersPerUnit = 1
)

def Xform "Level"
{
    def Mesh "room_hall"
    {
        int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
        int[] faceVertexIndices = [0, 1, 3, 2, 4, 6, 7, 5, 0, 4, 5, 1, 2, 3, 7, 6, 0, 2, 6, 4, 1, 5, 7, 3]
        point3f[] points = [(0, 0, 0), (0, 0, 4), (0, 3, 0), (0, 3, 4), (4, 0, 0), (4, 0, 4), (4, 3, 0), (4, 3, 4)]
    }
}
"""


def box_brush(lo, hi, texture="stone"):
    """A box brush in the Quake format (make_samples.quake_box)."""
    return ms.quake_box(lo, hi, texture)


def room_map(extra=""):
    """A 256 x 256 x 128 unit room of 16 unit brushes with a player start inside."""
    t = 16
    boxes = [
        ((-t, -t, -t), (256 + t, 256 + t, 0)), ((-t, -t, 128), (256 + t, 256 + t, 128 + t)),
        ((-t, -t, 0), (0, 256 + t, 128)), ((256, -t, 0), (256 + t, 256 + t, 128)),
        ((0, -t, 0), (256, 0, 128)), ((0, 256, 0), (256, 256 + t, 128)),
    ]
    world = '{\n"classname" "worldspawn"\n' + "".join(box_brush(lo, hi) for lo, hi in boxes)
    return (world + extra + "}\n"
            + '{\n"classname" "info_player_start"\n"origin" "128 128 64"\n}\n')


def brush_maps():
    """Brush maps (.map) for the MAP_* codes."""
    (OUT / "MAP_SYNTAX.map").write_text(
        '// a brush whose closing brace is missing\n{\n"classname" "worldspawn"\n{\n'
        "( 0 0 0 ) ( 0 1 0 ) ( 0 0 1 ) stone 0 0 0 1 1\n}\n")
    bad = "{\n( 0 0 0 ) ( 16 16 16 ) ( 32 32 32 ) stone 0 0 0 1 1\n" + box_brush((0, 0, 0), (8, 8, 8))[2:]
    (OUT / "MAP_BRUSH_INVALID.map").write_text(room_map(bad))
    patch = ("{\npatchDef2\n{\ncommon/caulk\n( 3 3 0 0 0 )\n(\n( ( 0 0 0 0 0 ) ( 0 8 0 0 1 ) ( 0 16 0 0 2 ) )\n"
             "( ( 8 0 0 1 0 ) ( 8 8 8 1 1 ) ( 8 16 0 1 2 ) )\n( ( 16 0 0 2 0 ) ( 16 8 0 2 1 ) ( 16 16 0 2 2 ) )\n)\n}\n}\n")
    (OUT / "MAP_PATCHES_SKIPPED.map").write_text(room_map(patch))


def main():
    if OUT.exists():
        shutil.rmtree(OUT)
    OUT.mkdir(parents=True)
    for name, (tree, post) in level_samples().items():
        write(tree, name, post)
    for name, doc in annotated_samples().items():
        write_doc(doc, name)
    copies()
    written()
    brush_maps()
    shutil.copyfile(ROOT / "scripts" / "broken_README.md", OUT / "README.md")
    print("wrote", len(list(OUT.iterdir())), "entries in", OUT)


if __name__ == "__main__":
    main()
