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



# --- Portal samples: openings in a shared wall, a door through a thick wall, an arch, a mirror and a
# teleporter. Every surface is still a single-sided quad (or a strip of one); the self-check below
# says which shells are closed and how the open walls tile their rectangle.

def dot(u, v):
    return sum(u[k] * v[k] for k in range(3))


def facing(tris, n):
    """The triangles, each wound so that its normal points along n."""
    out = []
    for a, b, c in tris:
        d = dot(normal((a, b, c)), n)
        assert abs(d) > 1e-12, f"triangle {(a, b, c)} is degenerate or edge-on to {n}"
        out.append((a, b, c) if d > 0 else (a, c, b))
    return out


def fan(pts):
    """Triangle fan over a convex polygon given in cyclic order; repeated corners (a strip that
    narrows to a point) are dropped so no triangle is degenerate."""
    ring = [p for i, p in enumerate(pts) if p != pts[i - 1]]
    return [(ring[0], ring[k], ring[k + 1]) for k in range(1, len(ring) - 1)]


def wall_x(x, pieces, nx):
    """Convex pieces given as (z, y) rings in the plane x = const, facing +x (nx = 1) or -x (-1)."""
    tris = []
    for ring in pieces:
        tris += fan([(x, y, z) for z, y in ring])
    return facing(tris, (nx, 0, 0))


def rect_zy(z0, y0, z1, y1):
    return [(z0, y0), (z1, y0), (z1, y1), (z0, y1)]


def box_room(x0, x1, skip=()):
    """Inward-facing floor, ceiling and walls of a room [x0, x1] x [0, H] x [0, 4], without the
    x-walls whose x is in `skip` (those are built by the caller, or left open)."""
    z0, z1 = 0.0, 4.0
    floor = quad((x0, 0, z0), (x0, 0, z1), (x1, 0, z1), (x1, 0, z0))
    ceiling = quad((x0, H, z0), (x1, H, z0), (x1, H, z1), (x0, H, z1))
    walls = []
    walls += quad((x0, 0, z0), (x1, 0, z0), (x1, H, z0), (x0, H, z0))  # z = 0, faces +z
    walls += quad((x0, 0, z1), (x0, H, z1), (x1, H, z1), (x1, 0, z1))  # z = 4, faces -z
    for x, nx in ((x0, 1), (x1, -1)):
        if x not in skip:
            walls += wall_x(x, [rect_zy(z0, 0, z1, H)], nx)
    return floor, ceiling, walls


def voxel_solid(xs, ys, zs, solid):
    """Outward-facing closed surface of the union of the grid cells (i, j, k) of xs x ys x zs
    with solid(i, j, k): one quad per cell face between a solid cell and a non-solid one (or the
    outside). All faces lie on one grid, so the surface is conforming and closes edge for edge."""
    axes = (xs, ys, zs)
    size = [len(a) - 1 for a in axes]

    def filled(c):
        return all(0 <= c[a] < size[a] for a in range(3)) and solid(*c)

    tris = []
    for i in range(size[0]):
        for j in range(size[1]):
            for k in range(size[2]):
                c = (i, j, k)
                if not filled(c):
                    continue
                for a in range(3):
                    for side in (0, 1):
                        nb = list(c)
                        nb[a] += 1 if side else -1
                        if filled(nb):
                            continue
                        u, v = [b for b in range(3) if b != a]
                        (ua, ub), (va, vb) = [(axes[b][c[b]], axes[b][c[b] + 1]) for b in (u, v)]
                        corners = []
                        for pu, pv in ((ua, va), (ub, va), (ub, vb), (ua, vb)):
                            p = [0.0] * 3
                            p[a], p[u], p[v] = axes[a][c[a] + side], pu, pv
                            corners.append(tuple(p))
                        n = [0, 0, 0]
                        n[a] = 1 if side else -1
                        tris += facing(quad(*corners), n)
    return tris


WINDOWED = {  # door_window: the openings of the shared wall x = 4, (z0, y0, z1, y1)
    "door": (0.5, 0.0, 1.5, 2.2),
    "window": (2.5, 1.0, 3.5, 2.0),
}


def door_window():
    holes = list(WINDOWED.values())
    pieces = [rect_zy(*c) for c in grid_cells((0.0, 0.0, 4.0, H), holes)]
    rooms = []
    for name, (x0, x1), nx in (("west-room", (0.0, 4.0), -1), ("east-room", (4.0, 8.0), 1)):
        f, c, w = box_room(x0, x1, skip=(4.0,))
        rooms.append(room_node(name, f, c, w + wall_x(4.0, pieces, nx)))
    return level(*rooms)


THICK = (4.0, 4.3)               # the slab between west-room and east-room in thick_wall
THICK_DOOR = (1.5, 0.0, 2.5, 2.2)  # its door, (z0, y0, z1, y1)


def thick_wall():
    xa, xb = THICK
    dz0, dy0, dz1, dy1 = THICK_DOOR
    assert dy0 == 0.0
    # Cells of x [4, 4.3] x y [0, 2.2, 3] x z [0, 1.5, 2.5, 4]; the door is cell (0, 0, 1).
    slab = voxel_solid([xa, xb], [0.0, dy1, H], [0.0, dz0, dz1, 4.0],
                       lambda i, j, k: not (j == 0 and k == 1))
    wf, wc, ww = box_room(0.0, xa, skip=(xa,))
    ef, ec, ew = box_room(xb, xb + 4.0, skip=(xb,))
    west = room_node("west-room", wf, wc, ww)
    west["children"] += [
        {"name": "Wall", "tris": slab, "material": "wall"},
        {"name": "west-bound", "tris": box(0.0, 0.0, 0.0, xa, H, 4.0), "material": "bound"},
    ]
    return level(west, room_node("east-room", ef, ec, ew))


COURT = ((0.0, 4.0), (6.0, 10.0))  # courtyard: the two courts' x ranges, z 0..4
COURT_BACK = 6.0                    # height of each court's back wall (the others are H)


def lean_to(x_front, x_back, name):
    """A roofless court: floor [x0, x1] x [0, 4], a wall H high on the side facing the other
    court (x = x_front), one COURT_BACK high at the far side (x = x_back), side walls sloping
    between them, all facing in; no ceiling."""
    x0, x1 = min(x_front, x_back), max(x_front, x_back)
    z0, z1 = 0.0, 4.0
    floor = facing(quad((x0, 0, z0), (x0, 0, z1), (x1, 0, z1), (x1, 0, z0)), (0, 1, 0))
    into = 1 if x_back < x_front else -1  # +x faces in from the back wall's side
    walls = wall_x(x_front, [rect_zy(z0, 0, z1, H)], -into)
    walls += wall_x(x_back, [rect_zy(z0, 0, z1, COURT_BACK)], into)
    top = {x_front: H, x_back: COURT_BACK}
    for z, nz in ((z0, 1), (z1, -1)):
        side = [(x0, 0, z), (x1, 0, z), (x1, top[x1], z), (x0, top[x0], z)]
        walls += facing(fan(side), (0, 0, nz))
    return {"name": name, "children": [
        {"name": "Floor", "tris": floor, "material": "floor"},
        {"name": "Walls", "tris": walls, "material": "wall"},
    ]}


def courtyard():
    (a0, a1), (b0, b1) = COURT
    return level(lean_to(a1, a0, "west-room"), lean_to(b0, b1, "east-room"))


OFFSET = (4.0, 4.3)                  # offset_holes: the west room's wall, the east room's
OFFSET_HOLES = ((0.5, 0.0, 1.5, 2.2),  # the hole in x = 4, (z0, y0, z1, y1)
                (2.5, 0.0, 3.5, 2.2))  # the hole in x = 4.3


def offset_holes():
    """Two rooms 0.3 m apart, each wall with a door hole, the holes not facing each other: the
    hollow between the walls is open at its ends and top, and sight passes through it
    slantwise (from the west room through (4, 1, 1) to (4.3, 1, 3) and on)."""
    rooms = []
    for name, (x0, x1), wall, nx, hole in (("west-room", (0.0, OFFSET[0]), OFFSET[0], -1, OFFSET_HOLES[0]),
                                           ("east-room", (OFFSET[1], OFFSET[1] + 4.0), OFFSET[1], 1,
                                            OFFSET_HOLES[1])):
        f, c, w = box_room(x0, x1, skip=(wall,))
        pieces = [rect_zy(*r) for r in grid_cells((0.0, 0.0, 4.0, H), [hole])]
        rooms.append(room_node(name, f, c, w + wall_x(wall, pieces, nx)))
    return level(*rooms)


ARCH_SEGMENTS = 8


def arch_ring():
    """The fanlight: the half-disc of radius 1 about (z, y) = (2, 2) above y = 2 as a half-polygon
    of ARCH_SEGMENTS equal segments, corners from (3, 2) over the top to (1, 2)."""
    import math
    pts = []
    for k in range(ARCH_SEGMENTS + 1):
        t = math.pi * k / ARCH_SEGMENTS
        pts.append((2.0 + math.cos(t), 2.0 + math.sin(t)))
    # Snap the ends and the apex exactly (cos(pi/2) and sin(pi) are not quite 0 in floating point).
    pts[0], pts[-1] = (3.0, 2.0), (1.0, 2.0)
    if ARCH_SEGMENTS % 2 == 0:
        pts[ARCH_SEGMENTS // 2] = (2.0, 3.0)
    return pts


def arch_opening():
    """The opening as convex (z, y) rings: the doorway and the fanlight; their union is the
    non-convex arched opening (reflex at (1.5, 2) and (2.5, 2))."""
    return [rect_zy(1.5, 0.0, 2.5, 2.0), arch_ring()]


def arch_area():
    """Exact: 1 x 2 doorway plus half of a regular 2n-gon of radius 1, n segments of central angle
    pi/n: n * sin(pi/n) / 2. For n = 8, 4 sin(pi/8) = 2 sqrt(2 - sqrt 2)."""
    import math
    return 2.0 + ARCH_SEGMENTS * math.sin(math.pi / ARCH_SEGMENTS) / 2.0


def arch():
    ring = arch_ring()
    pieces = [rect_zy(0.0, 0.0, 1.0, H), rect_zy(1.0, 0.0, 1.5, 2.0),
              rect_zy(2.5, 0.0, 3.0, 2.0), rect_zy(3.0, 0.0, 4.0, H)]
    # Above the arch: one vertical strip per segment, from the segment up to the ceiling (the two
    # strips at the apex, which touches the ceiling, are triangles).
    for (za, ya), (zb, yb) in zip(ring, ring[1:]):
        pieces.append([(za, ya), (zb, yb), (zb, H), (za, H)])
    rooms = []
    for name, (x0, x1), nx in (("west-room", (0.0, 4.0), -1), ("east-room", (4.0, 8.0), 1)):
        f, c, w = box_room(x0, x1, skip=(4.0,))
        rooms.append(room_node(name, f, c, w + wall_x(4.0, pieces, nx)))
    return level(*rooms)


def mirror():
    hall = room_node("hall-room", *box_room(0.0, 4.0))
    hall["children"].append({
        "name": "Mirror", "tris": wall_x(4.0, [rect_zy(1.0, 0.5, 3.0, 2.5)], -1), "material": "portal",
        "extras": {"portal": True, "portal_kind": "mirror"}})
    return level(hall)


TELEPORT = {"tp_a": (4.0, -1, "tp_b"), "tp_b": (10.0, 1, "tp_a")}  # x, facing, exit


def teleporter():
    rooms = []
    for name, (x0, x1), tp in (("a-room", (0.0, 4.0), "tp_a"), ("b-room", (10.0, 14.0), "tp_b")):
        node = room_node(name, *box_room(x0, x1))
        x, nx, exit_ = TELEPORT[tp]
        node["children"].append({
            "name": tp, "tris": wall_x(x, [rect_zy(1.0, 0.0, 3.0, 2.0)], nx), "material": "portal",
            "extras": {"portal": True, "portal_kind": "teleporter", "teleport_exit": exit_}})
        rooms.append(node)
    return level(*rooms)

# --- 3D room samples: rooms whose section changes with height (soffit, platform, stairs,
# mezzanine), door reveals and a crawl tunnel, a vaulted ceiling and an arched passage. Each room
# is one closed inward-facing `Shell` (less its openings); the known answers are in
# samples/README.md and ROOMS_3D below, checked here and by tests/cells_3d.rs.

def flip(tris):
    return [(a, c, b) for a, b, c in tris]


def voxel_room(xs, ys, zs, air, open_faces=()):
    """Inward-facing surface of the union of the grid cells with air(i, j, k), less the faces
    whose every corner passes one of `open_faces` (predicates on a point): the openings."""
    tris = flip(voxel_solid(xs, ys, zs, air))
    return [t for t in tris if not any(all(f(p) for p in t) for f in open_faces)]


def shell_room(name, tris):
    return {"name": name, "children": [{"name": "Shell", "tris": tris, "material": "wall"}]}


def in_rect_x(x, z0, y0, z1, y1):
    """A predicate: the point lies on the plane x inside the (z, y) rectangle."""
    return lambda p: p[0] == x and z0 <= p[2] <= z1 and y0 <= p[1] <= y1


def soffit_hall():
    # 9 x 3 x 6 hall; the ceiling drops to 2.5 over x in [6, 9].
    return level(shell_room("hall-room", voxel_room(
        [0.0, 6.0, 9.0], [0.0, 2.5, H], [0.0, 6.0], lambda i, j, k: not (i == 1 and j == 1))))


def platform_hall():
    # 9 x 3 x 6 hall; the floor is 0.5 higher over x in [0, 4.5].
    return level(shell_room("hall-room", voxel_room(
        [0.0, 4.5, 9.0], [0.0, 0.5, H], [0.0, 6.0], lambda i, j, k: not (i == 0 and j == 0))))


STAIR = (4, 2.0, 0.5)  # steps, tread (x), rise (y); floor and ceiling (3 m above) rise together


def stair_hall():
    n, tread, rise = STAIR
    xs = [tread * i for i in range(n + 1)]
    ys = sorted({rise * i for i in range(n)} | {H + rise * i for i in range(n)})

    def air(i, j, k):
        return ys[j] >= rise * i and ys[j + 1] <= H + rise * i

    return level(shell_room("stair-room", voxel_room(xs, ys, [0.0, 4.0], air)))


def mezzanine_hall():
    # 9 x 6 x 6 hall with a 0.3 m slab over x in [0, 4.5] at y in [3, 3.3], wall to wall in z.
    return level(shell_room("hall-room", voxel_room(
        [0.0, 4.5, 9.0], [0.0, 3.0, 3.3, 6.0], [0.0, 6.0], lambda i, j, k: not (i == 0 and j == 1))))


REVEAL = (4.0, 4.5, 1.5, 2.5, 2.2)  # wall x from, to; door z from, to, height


def door_reveal():
    xa, xb, dz0, dz1, dh = REVEAL
    zs = [0.0, dz0, dz1, 4.0]
    # west-room owns the tunnel through the wall; it opens onto east-room at x = xb.
    west = voxel_room([0.0, xa, xb], [0.0, dh, H], zs,
                      lambda i, j, k: i == 0 or (j == 0 and k == 1),
                      [in_rect_x(xb, dz0, 0.0, dz1, dh)])
    east = voxel_room([xb, xb + 4.0], [0.0, dh, H], zs, lambda i, j, k: True,
                      [in_rect_x(xb, dz0, 0.0, dz1, dh)])
    return level(shell_room("west-room", west), shell_room("east-room", east))


CRAWL = (4.0, 6.0, 1.5, 2.5, 1.0)  # tunnel x from, to; z from, to; height


def crawl_tunnel():
    xa, xb, dz0, dz1, dh = CRAWL
    zs = [0.0, dz0, dz1, 4.0]
    ys = [0.0, dh, H]
    a = voxel_room([0.0, xa], ys, zs, lambda i, j, k: True, [in_rect_x(xa, dz0, 0.0, dz1, dh)])
    t = voxel_room([xa, xb], [0.0, dh], [dz0, dz1], lambda i, j, k: True,
                   [in_rect_x(xa, dz0, 0.0, dz1, dh), in_rect_x(xb, dz0, 0.0, dz1, dh)])
    b = voxel_room([xb, xb + 4.0], ys, zs, lambda i, j, k: True, [in_rect_x(xb, dz0, 0.0, dz1, dh)])
    return level(shell_room("west-room", a), shell_room("tunnel-room", t), shell_room("east-room", b))


def half_polygon(cz, cy, r, n):
    """The upper half of a regular 2n-gon about (cz, cy), corners from (cz + r, cy) over the top
    to (cz - r, cy), ends and apex snapped exactly."""
    import math
    pts = [(cz + r * math.cos(math.pi * k / n), cy + r * math.sin(math.pi * k / n)) for k in range(n + 1)]
    pts[0], pts[-1] = (cz + r, cy), (cz - r, cy)
    if n % 2 == 0:
        pts[n // 2] = (cz, cy + r)
    return pts


def prism_x(ring, x0, x1, caps=(True, True)):
    """Inward-facing surface of the prism over the convex (z, y) ring (counter-clockwise in the
    (z, y) plane) from x0 to x1, with its end caps where asked."""
    tris = []
    for (za, ya), (zb, yb) in zip(ring, ring[1:] + ring[:1]):
        tris += flip(quad((x0, ya, za), (x1, ya, za), (x1, yb, zb), (x0, yb, zb)))
    if caps[0]:
        tris += wall_x(x0, [ring], 1)
    if caps[1]:
        tris += wall_x(x1, [ring], -1)
    return tris


VAULT = (8.0, 6.0, 4.0, 8)  # length (x), width (z), wall height, vault segments


def vaulted_hall():
    length, width, wall, n = VAULT
    ring = [(width, 0.0), (width, wall)] + half_polygon(width / 2, wall, width / 2, n)[1:-1] + \
        [(0.0, wall), (0.0, 0.0)]
    return level(shell_room("nave-room", prism_x(ring, 0.0, length)))


ARCH_PASSAGE = (4.0, 4.5, 1.5, 2.5, 2.0, 8)  # wall x from, to; z from, to; spring height; segments


def arch_passage_ring():
    xa, xb, z0, z1, spring, n = ARCH_PASSAGE
    return [(z0, 0.0), (z1, 0.0)] + half_polygon((z0 + z1) / 2, spring, (z1 - z0) / 2, n)


def arch_passage():
    """Two rooms through a 0.5 m wall; the round-arched passage belongs to west-room."""
    xa, xb, z0, z1, spring, n = ARCH_PASSAGE
    ring = arch_passage_ring()
    arc = ring[2:]
    pieces = [rect_zy(0.0, 0.0, z0, H), rect_zy(z1, 0.0, 4.0, H)]
    for (za, ya), (zb, yb) in zip(arc, arc[1:]):
        pieces.append([(za, ya), (zb, yb), (zb, H), (za, H)])
    wf, wc, ww = box_room(0.0, xa, skip=(xa,))
    ef, ec, ew = box_room(xb, xb + 4.0, skip=(xb,))
    # The passage's sides, floor and vault; open at both ends (onto west-room and east-room).
    passage = prism_x(ring, xa, xb, caps=(False, False))
    west = wf + wc + ww + wall_x(xa, pieces, -1) + passage
    east = ef + ec + ew + wall_x(xb, pieces, 1)
    return level(shell_room("west-room", west), shell_room("east-room", east))


def arch_passage_area():
    xa, xb, z0, z1, spring, n = ARCH_PASSAGE
    import math
    r = (z1 - z0) / 2
    return (z1 - z0) * spring + n * r * r * math.sin(math.pi / n) / 2.0


# Known answers: cells per room and the room's volume (m³).
ROOMS_3D = {
    "soffit_hall": {"hall": (2, 9 * 2.5 * 6 + 6 * 0.5 * 6)},
    "platform_hall": {"hall": (2, 9 * 3 * 6 - 4.5 * 0.5 * 6)},
    "stair_hall": {"stair": (4, 4 * 2.0 * 3.0 * 4.0)},
    "mezzanine_hall": {"hall": (3, 9 * 6 * 6 - 4.5 * 0.3 * 6)},
    "door_reveal": {"west": (2, 4 * 3 * 4 + 0.5 * 1.0 * 2.2), "east": (1, 4 * 3 * 4)},
    "crawl_tunnel": {"west": (1, 48.0), "tunnel": (1, 2.0 * 1.0 * 1.0), "east": (1, 48.0)},
}


def self_check_3d(samples):
    for name, rooms in ROOMS_3D.items():
        for room, (_, volume) in rooms.items():
            tris = node_at(samples[name], f"{room}-room/Shell")["tris"]
            if name in ("door_reveal", "crawl_tunnel"):
                continue  # open rooms: checked by the tests' ray oracle
            check_shell(tris, -volume, f"{name}/{room}")
    import math
    length, width, wall, n = VAULT
    vault = length * (width * wall + n * (width / 2) ** 2 * math.sin(math.pi / n) / 2)
    check_shell(node_at(samples["vaulted_hall"], "nave-room/Shell")["tris"], -vault, "vaulted_hall")


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



def node_at(tree, path):
    """The node at `path` (names joined by '/') below `tree`."""
    for name in path.split("/"):
        tree = next(c for c in tree["children"] if c["name"] == name)
    return tree


def area(t):
    return sum(k * k for k in normal(t)) ** 0.5 / 2.0


def ring_area(ring):
    return abs(sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(ring, ring[1:] + ring[:1]))) / 2.0


def check_faces_into(tris, centre, what):
    """Every triangle's front (its winding's normal) looks towards `centre` (rooms here are boxes,
    so this is exactly "faces into the room")."""
    for t in tris:
        mid = [sum(p[k] for p in t) / 3.0 for k in range(3)]
        to = [centre[k] - mid[k] for k in range(3)]
        assert dot(normal(t), to) > 0, f"{what}: triangle {t} faces away from {centre}"


def check_tiling(tris, x, rect, openings, what):
    """The triangles lie in the plane x = const and tile the (z, y) rectangle `rect` minus the
    convex `openings` (disjoint interiors) exactly: the areas add up, and every point of a fine
    lattice is covered by one triangle outside the openings and by none inside them."""
    z0, y0, z1, y1 = rect
    pts = [p for t in tris for p in t]
    assert all(p[0] == x for p in pts), f"{what}: not all in the plane x = {x}"
    assert all(z0 <= p[2] <= z1 and y0 <= p[1] <= y1 for p in pts), f"{what}: outside its rectangle"
    want = (z1 - z0) * (y1 - y0) - sum(ring_area(r) for r in openings)
    got = sum(area(t) for t in tris)
    assert abs(got - want) < 1e-9, f"{what}: area {got}, expected {want}"

    def side(a, b, p):
        return (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])

    def inside(ring, p):
        """1 strictly inside the convex ring, 0 strictly outside, None too close to its boundary."""
        s = [side(a, b, p) for a, b in zip(ring, ring[1:] + ring[:1])]
        if all(v > 1e-9 for v in s) or all(v < -1e-9 for v in s):
            return 1
        if any(abs(v) <= 1e-9 for v in s) and not any(v > 1e-9 for v in s) or \
                any(abs(v) <= 1e-9 for v in s) and not any(v < -1e-9 for v in s):
            return None
        return 0

    flat = [[(p[2], p[1]) for p in t] for t in tris]
    nz, ny = 97, 71
    for i in range(nz):
        for j in range(ny):
            p = (z0 + (i + 0.5) * (z1 - z0) / nz, y0 + (j + 0.5) * (y1 - y0) / ny)
            cover = [inside(t, p) for t in flat]
            hole = [inside(r, p) for r in openings]
            if None in cover or None in hole:
                continue
            want = 0 if any(hole) else 1
            assert sum(cover) == want, f"{what}: {p} covered {sum(cover)} times, expected {want}"


def room_tris(room):
    return [t for c in room["children"] if c["name"] in ("Floor", "Walls", "Ceiling") for t in c["tris"]]


def check_box_room(room, x0, x1, what, close_x=None):
    """A box room [x0, x1] x [0, H] x [0, 4]: faces into the room, floor up, ceiling down, and
    closed with volume -(its volume). A room open at x = close_x (its wall there has holes, or is
    missing) is checked closed with that wall replaced by the full rectangle instead."""
    centre = ((x0 + x1) / 2, H / 2, 2.0)
    tris = room_tris(room)
    check_faces_into(tris, centre, what)
    assert all(normal(t)[1] > 0 for t in node_at(room, "Floor")["tris"]), f"{what}: floor not up"
    assert all(normal(t)[1] < 0 for t in node_at(room, "Ceiling")["tris"]), f"{what}: ceiling not down"
    if close_x is not None:
        tris = [t for t in tris if not all(p[0] == close_x for p in t)]
        tris += wall_x(close_x, [rect_zy(0.0, 0.0, 4.0, H)], 1 if close_x == x0 else -1)
    check_shell(tris, -(x1 - x0) * H * 4.0, what)


def self_check_portals(samples):
    # Two rooms open to each other through holes in their own surfaces on the shared plane x = 4.
    for name, openings in (("door_window", [rect_zy(*r) for r in WINDOWED.values()]),
                           ("arch", arch_opening())):
        tree = samples[name]
        shared = []
        for room, x0, x1 in (("west-room", 0.0, 4.0), ("east-room", 4.0, 8.0)):
            what = f"{name}/{room}"
            node = node_at(tree, room)
            check_box_room(node, x0, x1, what, close_x=4.0)
            wall = [t for t in node_at(node, "Walls")["tris"] if all(p[0] == 4.0 for p in t)]
            check_tiling(wall, 4.0, (0.0, 0.0, 4.0, H), openings, f"{what} wall x = 4")
            shared.append(sorted(tuple(sorted(t)) for t in wall))
        assert shared[0] == shared[1], f"{name}: the two rooms' surfaces at x = 4 differ"
    assert abs(sum(ring_area(r) for r in arch_opening()) - arch_area()) < 1e-12, "arch: area formula"

    # Thick wall: both rooms open on the slab side; the slab and the bound box are closed and face out.
    tree = samples["thick_wall"]
    xa, xb = THICK
    check_box_room(node_at(tree, "west-room"), 0.0, xa, "thick_wall/west-room", close_x=xa)
    check_box_room(node_at(tree, "east-room"), xb, xb + 4.0, "thick_wall/east-room", close_x=xb)
    slab = node_at(tree, "west-room/Wall")["tris"]
    dz0, dy0, dz1, dy1 = THICK_DOOR
    check_shell(slab, (xb - xa) * (H * 4.0 - (dz1 - dz0) * (dy1 - dy0)), "thick_wall/west-room/Wall")
    for x in THICK:
        side_tris = [t for t in slab if all(p[0] == x for p in t)]
        assert all(normal(t)[0] * (x - (xa + xb) / 2) > 0 for t in side_tris), "slab side faces in"
        check_tiling(side_tris, x, (0.0, 0.0, 4.0, H), [rect_zy(*THICK_DOOR)], f"thick_wall slab x = {x}")
    check_shell(node_at(tree, "west-room/west-bound")["tris"], xa * H * 4.0, "thick_wall/west-bound")

    # Mirror: a quad on the wall x = 4, facing into the hall.
    tree = samples["mirror"]
    hall = node_at(tree, "hall-room")
    check_box_room(hall, 0.0, 4.0, "mirror/hall-room")
    m = node_at(hall, "Mirror")["tris"]
    check_tiling(m, 4.0, (1.0, 0.5, 3.0, 2.5), [], "mirror/Mirror")
    check_faces_into(m, (2.0, H / 2, 2.0), "mirror/Mirror")

    # Teleporter: quads on the walls x = 4 and x = 10, each facing into its room, naming each other;
    # the transform (entry frame, half a turn about up, exit frame) works out as a translation.
    tree = samples["teleporter"]
    frames = {}
    for room, x0, x1 in (("a-room", 0.0, 4.0), ("b-room", 10.0, 14.0)):
        node = node_at(tree, room)
        check_box_room(node, x0, x1, f"teleporter/{room}")
        tp = next(c for c in node["children"] if c["name"] in TELEPORT)
        x, nx, exit_ = TELEPORT[tp["name"]]
        assert tp["extras"]["teleport_exit"] == exit_ and exit_ != tp["name"]
        check_tiling(tp["tris"], x, (1.0, 0.0, 3.0, 2.0), [], f"teleporter/{tp['name']}")
        check_faces_into(tp["tris"], ((x0 + x1) / 2, H / 2, 2.0), f"teleporter/{tp['name']}")
        corners = sorted({p for t in tp["tris"] for p in t})
        frames[tp["name"]] = ([sum(p[k] for p in corners) / len(corners) for k in range(3)], nx)
    (ca, na), (cb, nb) = frames["tp_a"], frames["tp_b"]
    # Frame axes (normal, up, normal x up) as rows; the half turn about up is diag(-1, 1, -1).
    fa = [[na, 0, 0], [0, 1, 0], [0, 0, -na]]
    fb = [[nb, 0, 0], [0, 1, 0], [0, 0, -nb]]
    half = [-1, 1, -1]
    lin = [[sum(fb[k][r] * half[k] * fa[k][c] for k in range(3)) for c in range(3)] for r in range(3)]
    move = [cb[r] - sum(lin[r][c] * ca[c] for c in range(3)) for r in range(3)]
    assert lin == [[1, 0, 0], [0, 1, 0], [0, 0, 1]] and move == [6.0, 0.0, 0.0], (lin, move)
    assert ca == [4.0, 1.0, 2.0] and cb == [10.0, 1.0, 2.0]

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
                    # `unshared`: every corner its own vertex, as exporters that write walls
                    # of no height (a Doom sector whose floor and ceiling meet) do.
                    if t.get("unshared") or v not in index:
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
        if t.get("translation"):
            node["translation"] = list(t["translation"])
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


# ---- Rooms built of solid blocks: every slab, wall, jamb, lintel and pillar a closed,
# outward-facing box of its own (as Godot CSG boxes, Blender cubes or brushes are). The air
# between them is the room.

def hexa(p):
    """Outward-facing closed hexahedron from 8 corners indexed xi*4 + yi*2 + zi, like box()."""
    f = []
    f += quad(p[0], p[1], p[3], p[2])
    f += quad(p[4], p[6], p[7], p[5])
    f += quad(p[0], p[4], p[5], p[1])
    f += quad(p[2], p[3], p[7], p[6])
    f += quad(p[0], p[2], p[6], p[4])
    f += quad(p[1], p[5], p[7], p[3])
    return f


def block(name, b, material="wall", extras=None):
    node = {"name": name, "tris": box(*b), "material": material}
    if extras:
        node["extras"] = extras
    return node


def start(at):
    return {"name": "player_start", "extras": {"player_start": True}, "translation": at}


def slab_room(name, x0, x1, z0, z1, h, t, ceiling=True, skip=(), extra=(), west=None):
    """Floor, ceiling and four walls of thickness t around the air [x0,x1] x [0,h] x [z0,z1]:
    the long (z) walls run the full length, the short (x) walls butt between them. `west`
    moves the slabs' west end (to stop at a neighbour's wall)."""
    w = x0 - t if west is None else west
    parts = [block("floor", (w, -t, z0 - t, x1 + t, 0, z1 + t), "floor")]
    if ceiling:
        parts.append(block("ceiling", (w, h, z0 - t, x1 + t, h + t, z1 + t)))
    walls = {
        "wall_south": (w, 0, z0 - t, x1 + t, h, z0),
        "wall_north": (w, 0, z1, x1 + t, h, z1 + t),
        "wall_west": (x0 - t, 0, z0, x0, h, z1),
        "wall_east": (x1, 0, z0, x1 + t, h, z1),
    }
    parts += [block(k, v) for k, v in walls.items() if k not in skip]
    parts += list(extra)
    return {"name": name, "children": parts}


def block_closet():
    return level(slab_room("closet-room", 0, 2, 0, 2, 2.5, 0.3))


def block_hall():
    return level(slab_room("hall-room", 0, 6, 0, 4, 3, 0.5))


def block_butt_joints():
    """The short walls butt between the long ones, the long ones between floor and ceiling."""
    return level(slab_room("hall-room", 0, 5, 0, 3, 3, 0.25))


def block_corners():
    """Mitred corners at x = 0 (45-degree ends meeting on the diagonal), overlapping corners
    at x = 4 (the long walls run through the end wall)."""
    L, W, h, t = 4.0, 3.0, 3.0, 0.3

    def wall_z(z_in, z_out):
        # Mitred at x = 0, square (overlapping the east wall) at x = L + t.
        p = []
        for xi in (0, 1):
            for y in (0, h):
                for zi in (0, 1):
                    z = (z_out, z_in)[zi] if z_out < z_in else (z_in, z_out)[zi]
                    outer = z == z_out
                    x = (-t if outer else 0.0) if xi == 0 else L + t
                    p.append((x, y, z))
        return hexa(p)

    west = []
    for xi in (0, 1):
        for y in (0, h):
            for zi in (0, 1):
                x = (-t, 0.0)[xi]
                z = (-t, W + t)[zi] if xi == 0 else (0.0, W)[zi]
                west.append((x, y, z))
    parts = [
        block("floor", (-t, -t, -t, L + t, 0, W + t), "floor"),
        block("ceiling", (-t, h, -t, L + t, h + t, W + t)),
        {"name": "wall_south", "tris": wall_z(0.0, -t), "material": "wall"},
        {"name": "wall_north", "tris": wall_z(W, W + t), "material": "wall"},
        {"name": "wall_west", "tris": hexa(west), "material": "wall"},
        block("wall_east", (L, 0, -t, L + t, h, W + t)),
    ]
    return level({"name": "hall-room", "children": parts})


def block_door():
    """Two 4 x 3 x 4 m rooms through a 0.3 m wall (room a's) with a 1 x 2.1 m door: two wall
    blocks are the jambs, a lintel block spans the door above 2.1 m."""
    h, t = 3.0, 0.3
    a = slab_room("a-room", 0, 4, 0, 4, h, t, skip=("wall_east",), extra=(
        block("jamb_south", (4, 0, -t, 4 + t, h, 1.5)),
        block("jamb_north", (4, 0, 2.5, 4 + t, h, 4 + t)),
        block("lintel", (4, 2.1, 1.5, 4 + t, h, 2.5)),
    ))
    b = slab_room("b-room", 4 + t, 8 + t, 0, 4, h, t, skip=("wall_west",), west=4 + t)
    return level(a, b)


def block_slot_leak():
    """The closet with a 10 cm slot through its east wall, floor to ceiling: a leak."""
    t = 0.3
    c = slab_room("closet-room", 0, 2, 0, 2, 2.5, t, skip=("wall_east",), extra=(
        block("wall_east_a", (2, 0, 0, 2 + t, 2.5, 0.95)),
        block("wall_east_b", (2, 0, 1.05, 2 + t, 2.5, 2)),
    ))
    return level(c, start((1.0, 1.0, 1.0)))


def block_roofless():
    """Walls and floor, no ceiling: open to the sky."""
    return level(slab_room("yard-room", 0, 4, 0, 3, 2.5, 0.3, ceiling=False))


def block_pillar_hall():
    """A 6 x 3 x 4 m hall with a 0.6 x 0.6 m pillar from floor to ceiling (structure) and a
    table tagged -detail (rendered, never carved)."""
    return level(slab_room("hall-room", 0, 6, 0, 4, 3, 0.5, extra=(
        block("pillar", (2.7, 0, 1.7, 3.3, 3, 2.3)),
        block("table-detail", (4.5, 0, 0.5, 5.5, 0.8, 1.3), "wood"),
    )))


def block_crate_in_wall():
    """The closet with a 0.8 m crate pushed 0.4 m into its east wall: a prop."""
    return level(slab_room("closet-room", 0, 2, 0, 2, 2.5, 0.3, extra=(
        block("crate", (1.6, 0, 0.6, 2.4, 0.8, 1.4), "wood"),
    )))


BLOCK_SAMPLES = {
    "block_closet": block_closet, "block_hall": block_hall,
    "block_butt_joints": block_butt_joints, "block_corners": block_corners,
    "block_door": block_door, "block_slot_leak": block_slot_leak,
    "block_roofless": block_roofless, "block_pillar_hall": block_pillar_hall,
    "block_crate_in_wall": block_crate_in_wall,
}


def check_blocks_closed(name, tree):
    """Every block is a closed, outward-facing solid with positive volume."""
    for path, t in flatten(tree):
        if "tris" not in t:
            continue
        edges = {}
        for tri in t["tris"]:
            for i in range(3):
                e = (tri[i], tri[(i + 1) % 3])
                edges[e] = edges.get(e, 0) + 1
        for (a, b), n in edges.items():
            assert edges.get((b, a), 0) == n, f"{name}/{path}: open edge {a}-{b}"
        vol = sum(dot(t0, cross(t1, t2)) for t0, t1, t2 in t["tris"]) / 6.0
        assert vol > 0, f"{name}/{path}: faces in (volume {vol})"


def cross(u, v):
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


# ---- No sightline lost (issue 43): two rooms whose air overlaps, a 4 cm wedge cell, and jambs
# modelled in the reveal of a door through a thick wall.

def overlap_rooms():
    """west-room x 0..5 and east-room x 4..8 (z 0..4, height 3): box shells, each without the
    wall facing the other, so their air overlaps over x 4..5."""
    wf, wc, ww = box_room(0.0, 5.0, skip=(5.0,))
    ef, ec, ew = box_room(4.0, 8.0, skip=(4.0,))
    return level(room_node("west-room", wf, wc, ww), room_node("east-room", ef, ec, ew))


WEDGE = (3.0, 6.0, 9.0, 0.04)  # the north wall's bend: from x, corner x, to x; how far out (m)


def prism_up(ring, y0, y1):
    """Outward-facing closed prism over the convex (x, z) ring from y0 to y1 (a bound)."""
    cx = sum(x for x, _ in ring) / len(ring)
    cz = sum(z for _, z in ring) / len(ring)
    tris = facing(fan([(x, y0, z) for x, z in ring]), (0, -1, 0))
    tris += facing(fan([(x, y1, z) for x, z in ring]), (0, 1, 0))
    for (xa, za), (xb, zb) in zip(ring, ring[1:] + ring[:1]):
        mx, mz = (xa + xb) / 2 - cx, (za + zb) / 2 - cz
        tris += facing(quad((xa, y0, za), (xb, y0, zb), (xb, y1, zb), (xa, y1, za)), (mx, 0, mz))
    return tris


def wedge_room():
    """hall-room x 0..12, z 0..4, height 3, whose north wall bends out at x = 6 to z = 4.04
    between x = 3 and x = 9; its bounds make three cells: west x 0..6, east x 6..12, and the
    wedge between z = 4 and the bend, 4 cm at its widest."""
    xa, xq, xb, d = WEDGE
    outline = [(0.0, 0.0), (0.0, 4.0), (xa, 4.0), (xq, 4.0 + d), (xb, 4.0), (12.0, 4.0), (12.0, 0.0)]
    floor = facing(fan([(x, 0.0, z) for x, z in [(0.0, 0.0), (0.0, 4.0), (12.0, 4.0), (12.0, 0.0)]]), (0, 1, 0))
    ceiling = facing(fan([(x, H, z) for x, z in [(0.0, 0.0), (0.0, 4.0), (12.0, 4.0), (12.0, 0.0)]]), (0, -1, 0))
    wedge = [(xa, 4.0), (xq, 4.0 + d), (xb, 4.0)]
    floor += facing(fan([(x, 0.0, z) for x, z in wedge]), (0, 1, 0))
    ceiling += facing(fan([(x, H, z) for x, z in wedge]), (0, -1, 0))
    walls = []
    for (x0, z0), (x1, z1) in zip(outline, outline[1:] + outline[:1]):
        walls += facing(quad((x0, 0, z0), (x1, 0, z1), (x1, H, z1), (x0, H, z0)), (z1 - z0, 0, x0 - x1))
    room = room_node("hall-room", floor, ceiling, walls)
    room["children"] += [
        {"name": "Bound_west", "tris": box(0.0, 0.0, 0.0, xq, H, 4.0), "material": "bound"},
        {"name": "Bound_east", "tris": box(xq, 0.0, 0.0, 12.0, H, 4.0), "material": "bound"},
        {"name": "Bound_wedge", "tris": prism_up(wedge, 0.0, H), "material": "bound"},
    ]
    return level(room)


JAMBS = (4.0, 4.5, 1.5, 2.5, 2.2)  # wall x from, to; door z from, to, height


def reveal_jambs():
    """west-room x 0..4 and east-room x 4.5..8.5 (z 0..4, height 3), box shells with a door
    hole z 1.5..2.5, y 0..2.2 in the wall facing the other; between the walls, 0.5 m of wall
    but for the doorway, whose jambs, lintel and sill are the node DoorFrame, in no room."""
    xa, xb, dz0, dz1, dh = JAMBS
    around = [rect_zy(0.0, 0.0, dz0, H), rect_zy(dz1, 0.0, 4.0, H), rect_zy(dz0, dh, dz1, H)]
    wf, wc, ww = box_room(0.0, xa, skip=(xa,))
    ww += wall_x(xa, around, -1)
    ef, ec, ew = box_room(xb, xb + 4.0, skip=(xb,))
    ew += wall_x(xb, around, 1)
    reveal = facing(quad((xa, 0, dz0), (xb, 0, dz0), (xb, dh, dz0), (xa, dh, dz0)), (0, 0, 1))
    reveal += facing(quad((xa, 0, dz1), (xb, 0, dz1), (xb, dh, dz1), (xa, dh, dz1)), (0, 0, -1))
    reveal += facing(quad((xa, dh, dz0), (xb, dh, dz0), (xb, dh, dz1), (xa, dh, dz1)), (0, -1, 0))
    reveal += facing(quad((xa, 0, dz0), (xb, 0, dz0), (xb, 0, dz1), (xa, 0, dz1)), (0, 1, 0))
    return level(room_node("west-room", wf, wc, ww), room_node("east-room", ef, ec, ew),
                 {"name": "DoorFrame", "tris": reveal, "material": "trim"})


# ---- A brush map (.map, Quake format): two rooms of brushes through a doorway, a player
# start, a func_detail crate and a light. Units are Quake's (inches, Z up).

def quake_box(lo, hi, texture):
    """A box brush: three points a face, (p0 - p1) x (p2 - p1) pointing out (qbsp's rule)."""
    axes = [(1, 0, 0), (0, 1, 0), (0, 0, 1)]
    lines = ["{"]
    for k in range(3):
        for sign, at in ((1, hi), (-1, lo)):
            a, b = axes[(k + 1) % 3], axes[(k + 2) % 3]
            if sign < 0:
                a, b = b, a
            q = [lo[i] if i != k else at[k] for i in range(3)]
            p0 = [q[i] + 16 * a[i] for i in range(3)]
            p2 = [q[i] + 16 * b[i] for i in range(3)]
            pt = lambda p: "( %g %g %g )" % tuple(p)
            lines.append(f"{pt(p0)} {pt(q)} {pt(p2)} {texture} 0 0 0 1 1")
    lines.append("}")
    return "\n".join(lines) + "\n"


def brush_rooms_map():
    """Rooms x 0..256 and 272..528 (y 0..256, z 0..128) through a 16 unit wall with a door
    y 96..160, z 0..96; 16 unit slabs all round."""
    t = 16
    world = [
        ((-t, -t, -t), (528 + t, 256 + t, 0), "floor"),
        ((-t, -t, 128), (528 + t, 256 + t, 128 + t), "ceiling"),
        ((-t, -t, 0), (0, 256 + t, 128), "wall"),
        ((528, -t, 0), (528 + t, 256 + t, 128), "wall"),
        ((0, -t, 0), (528, 0, 128), "wall"),
        ((0, 256, 0), (528, 256 + t, 128), "wall"),
        ((256, 0, 0), (272, 96, 128), "wall"),
        ((256, 160, 0), (272, 256, 128), "wall"),
        ((256, 96, 96), (272, 160, 128), "lintel"),
    ]
    out = ["// portcullis sample: two rooms of brushes through a doorway (Quake format)",
           '{\n"classname" "worldspawn"']
    out += [quake_box(lo, hi, tex).rstrip("\n") for lo, hi, tex in world]
    out.append("}")
    out.append('{\n"classname" "func_detail"\n' + quake_box((64, 64, 0), (96, 96, 32), "crate").rstrip("\n") + "\n}")
    out.append('{\n"classname" "info_player_start"\n"origin" "128 128 40"\n"angle" "90"\n}')
    out.append('{\n"classname" "light"\n"origin" "400 128 100"\n"light" "300"\n}')
    return "\n".join(out) + "\n"


def brush_doors_map():
    """Rooms A, B, C (x 0..256, 272..528, 544..800; y 0..256, z 0..128) through 16 unit walls
    with doorways y 96..160, z 0..96: a func_door brush fills the first doorway exactly; a
    func_areaportal brush 4 units thick (x 534..538) stands in the middle of the second."""
    t = 16
    world = [
        ((-t, -t, -t), (800 + t, 256 + t, 0), "floor"),
        ((-t, -t, 128), (800 + t, 256 + t, 128 + t), "ceiling"),
        ((-t, -t, 0), (0, 256 + t, 128), "wall"),
        ((800, -t, 0), (800 + t, 256 + t, 128), "wall"),
        ((0, -t, 0), (800, 0, 128), "wall"),
        ((0, 256, 0), (800, 256 + t, 128), "wall"),
    ]
    for x in (256, 528):
        world += [((x, 0, 0), (x + t, 96, 128), "wall"),
                  ((x, 160, 0), (x + t, 256, 128), "wall"),
                  ((x, 96, 96), (x + t, 160, 128), "lintel")]
    out = ["// portcullis sample: three rooms of brushes, a door and an area portal (Quake format)",
           '{\n"classname" "worldspawn"']
    out += [quake_box(lo, hi, tex).rstrip("\n") for lo, hi, tex in world]
    out.append("}")
    out.append('{\n"classname" "func_door"\n"angle" "-1"\n'
               + quake_box((256, 96, 0), (272, 160, 96), "door").rstrip("\n") + "\n}")
    out.append('{\n"classname" "func_areaportal"\n'
               + quake_box((534, 96, 0), (538, 160, 96), "areaportal").rstrip("\n") + "\n}")
    out.append('{\n"classname" "info_player_start"\n"origin" "128 128 40"\n}')
    return "\n".join(out) + "\n"


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
    portal_samples = {"door_window": door_window(), "thick_wall": thick_wall(), "arch": arch(),
                      "mirror": mirror(), "teleporter": teleporter()}
    self_check_portals(portal_samples)
    for name, tree in portal_samples.items():
        write_gltf(tree, OUT / f"{name}.gltf")
        print("wrote", OUT / f"{name}.gltf")
    sight_samples = {"courtyard": courtyard(), "offset_holes": offset_holes()}
    for name, tree in sight_samples.items():
        write_gltf(tree, OUT / f"{name}.gltf")
        print("wrote", OUT / f"{name}.gltf")
    samples_3d = {"soffit_hall": soffit_hall(), "platform_hall": platform_hall(),
                  "stair_hall": stair_hall(), "mezzanine_hall": mezzanine_hall(),
                  "door_reveal": door_reveal(), "crawl_tunnel": crawl_tunnel(),
                  "vaulted_hall": vaulted_hall(), "arch_passage": arch_passage()}
    self_check_3d(samples_3d)
    for name, tree in samples_3d.items():
        write_gltf(tree, OUT / f"{name}.gltf")
        print("wrote", OUT / f"{name}.gltf")
    print(f"self-check passed: the 3D rooms' closed shells face in with their known volumes; "
          f"arched passage opening {arch_passage_area():.6f} m2")
    print("self-check passed: the portal samples' shells are closed (open walls closed by their "
          "rectangle), their open walls tile the rectangle minus the openings, every surface faces "
          f"the right way; arch opening area {arch_area():.6f}")
    for name, make in BLOCK_SAMPLES.items():
        tree = make()
        check_blocks_closed(name, tree)
        write_gltf(tree, OUT / f"{name}.gltf")
        print("wrote", OUT / f"{name}.gltf")
    print("self-check passed: every block is closed and faces out")
    sightline_samples = {"overlap_rooms": overlap_rooms(), "wedge_room": wedge_room(),
                         "reveal_jambs": reveal_jambs()}
    for name, tree in sightline_samples.items():
        write_gltf(tree, OUT / f"{name}.gltf")
        print("wrote", OUT / f"{name}.gltf")
    (OUT / "brush_rooms.map").write_text(brush_rooms_map())
    print("wrote", OUT / "brush_rooms.map")
    (OUT / "brush_doors.map").write_text(brush_doors_map())
    print("wrote", OUT / "brush_doors.map")
