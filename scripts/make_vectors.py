#!/usr/bin/env python3
"""Writes the cameras of tests/vectors/ (language-neutral test vectors for the runtime) and its
manifest. Python 3 standard library only; deterministic (no randomness: the same levels give
the same bytes). Run from anywhere:

    python3 scripts/make_vectors.py            # then: PORTCULLIS_BLESS=1 cargo test --test vectors

It converts every sample (samples/*.gltf, samples/*.map) and the two shared levels (when
../shared is there) with `target/release/portcullis` (or $PORTCULLIS), reads each converted
file's PORTCULLIS_portals extension (cells' planes and bounds, portals' polygons) and picks
cameras at the places a port of the runtime is most likely to get wrong:

- `centre`: a point inside each cell (the mean of its corners), looking along +x, -x, +z, -z;
- `face`: eyes exactly on a face two cells share (on both cells' boundaries, whether or not a
  portal covers it), looking across it both ways and along it;
- `hint`: such an eye after a camera in one of the two cells, then after one in the other
  (the previous camera's cell is the location hint, and wins the tie);
- `portal`: eyes on a portal's polygon, at its centroid and at its edges (just inside, on the
  edge, and beyond it in the plane by the near plane's reach less and more a hair);
- `reach`: eyes on a portal's axis at the near plane's reach (`View::near_radius`, the distance
  from the eye to the near plane's corners, plus the level's tolerance: crates/portcullis-runtime/src/runtime/trace.rs)
  less and more a hair, and within the tolerance of the plane, on both sides, looking at the
  portal, away from it and along it, with two fields of view;
- `transform`: looking into mirrors and teleporters from several places and angles;
- `outside`: eyes outside every cell looking in: beyond the level's bounds, outside exterior
  openings, and clipped into a wall (outside a cell's face by the near plane's reach less and
  more a hair, and further);

and for door portals (samples/door_window.gltf, samples/block_door.gltf,
samples/brush_doors.map) the same cameras again with doors closed (`--closed N`). The shared
levels get 200 cameras each of the same kinds. Each cameras file has a labels file beside it,
one line per camera, saying what the camera is for.

The expected answers are not written here: `PORTCULLIS_BLESS=1 cargo test --test vectors`
writes them (`cull --format jsonl --draw-lists`, without `stats`), and `cargo test --test
vectors` then checks them; `scripts/check_vectors.py` checks any other implementation.
"""
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "tests" / "vectors"
EXE = os.environ.get("PORTCULLIS") or str(ROOT / "target" / "release" / "portcullis")

# (level relative to the repository root, convert arguments, cameras wanted: None for all).
SHARED = [
    ("../shared/levels/freedoom/freedoom2_MAP01.glb", ["--tags", "doom"], 200),
    ("../shared/levels/ericw-tools/testmaps/E1M1-edited-ents.map", [], 200),
]
# Door openings to close, one case each, and all of them in one more case.
DOORS = {
    "samples/door_window.gltf": [[2], [0], [0, 2]],
    "samples/block_door.gltf": [[2], [0]],
    "samples/brush_doors.map": [[2], [4], [8], [2, 8]],
}

# Views: (fov_y degrees, aspect, near). The first is cull's default.
V0 = (60.0, 16.0 / 9.0, 0.05)
V1 = (90.0, 1.0, 0.1)
V2 = (40.0, 2.35, 0.2)
# A hair: far above rounding (coordinates are written to 1e-10), far below anything else.
HAIR = 1e-6


# --- vectors -------------------------------------------------------------------------------


def add(a, b):
    return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]


def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def mul(a, s):
    return [a[0] * s, a[1] * s, a[2] * s]


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def length(a):
    return math.sqrt(dot(a, a))


def unit(a):
    n = length(a)
    return mul(a, 1.0 / n) if n > 0 else None


def mean(points):
    n = len(points)
    return [sum(p[i] for p in points) / n for i in range(3)]


def newell(poly):
    n = [0.0, 0.0, 0.0]
    for i, a in enumerate(poly):
        b = poly[(i + 1) % len(poly)]
        n[0] += (a[1] - b[1]) * (a[2] + b[2])
        n[1] += (a[2] - b[2]) * (a[0] + b[0])
        n[2] += (a[0] - b[0]) * (a[1] + b[1])
    return n


def yaw(d, degrees):
    """`d` turned about +Y."""
    t = math.radians(degrees)
    c, s = math.cos(t), math.sin(t)
    return [c * d[0] + s * d[2], d[1], -s * d[0] + c * d[2]]


def pitch(d, degrees):
    """`d` tilted up (positive) or down, keeping its heading."""
    h = unit([d[0], 0.0, d[2]])
    if h is None:
        return d
    t = math.radians(degrees)
    return add(mul(h, math.cos(t)), [0.0, math.sin(t), 0.0])


def tangent(n):
    """A direction along the plane of normal `n`: horizontal when the plane is not."""
    t = cross(n, [0.0, 1.0, 0.0])
    if length(t) < 1e-6:
        t = cross(n, [0.0, 0.0, 1.0])
    return unit(t)


def near_radius(view):
    """As `View::near_radius`: the distance from the eye to the near plane's corners."""
    fov, aspect, near = view
    tan_y = math.tan(math.radians(fov) / 2.0)
    tan_x = tan_y * aspect
    return near * math.sqrt(1.0 + tan_x * tan_x + tan_y * tan_y)


# --- the level -----------------------------------------------------------------------------


def read_extension(path):
    data = Path(path).read_bytes()
    if data[:4] == b"glTF":
        length_ = struct.unpack("<I", data[12:16])[0]
        doc = json.loads(data[20 : 20 + length_])
    else:
        doc = json.loads(data)
    return doc["extensions"]["PORTCULLIS_portals"]


class Level:
    def __init__(self, ext):
        self.tol = ext["tolerance"]
        self.cells = []
        for c in ext["cells"]:
            planes = []
            for p in c["planes"]:
                n = p[:3]
                k = length(n)
                planes.append((mul(n, 1.0 / k), p[3] / k))
            lo, hi = c["bounds"]["min"], c["bounds"]["max"]
            self.cells.append({"planes": planes, "min": lo, "max": hi})
        for c in self.cells:
            c["corners"] = self.corners(c)
            c["inner"] = mean(c["corners"]) if c["corners"] else mean([c["min"], c["max"]])
        self.portals = []
        for i, p in enumerate(ext.get("portals", [])):
            poly = p["polygon"]
            cells = p["cells"]
            to = cells[1] if len(cells) > 1 else None
            self.portals.append(
                {
                    "index": i,
                    "poly": poly,
                    "centre": mean(poly),
                    # From the source cell into the target (the winding is counter-clockwise
                    # seen from the source).
                    "n": unit(mul(newell(poly), -1.0)),
                    "from": cells[0],
                    "to": to,
                    "kind": p.get("kind", "plain"),
                    "partner": p.get("partner"),
                    "door": bool(p.get("door")),
                    "internal": bool(p.get("internal")),
                }
            )
        if self.cells:
            self.lo = [min(c["min"][i] for c in self.cells) for i in range(3)]
            self.hi = [max(c["max"][i] for c in self.cells) for i in range(3)]
        else:
            self.lo, self.hi = [0.0] * 3, [0.0] * 3

    def corners(self, c):
        """The cell's corners: every three planes' meeting point inside the others."""
        planes = c["planes"]
        out = []
        slack = max(self.tol, 1e-9) * 4
        for i in range(len(planes)):
            for j in range(i + 1, len(planes)):
                for k in range(j + 1, len(planes)):
                    p = solve3(planes[i], planes[j], planes[k])
                    if p is None:
                        continue
                    if all(dot(n, p) - d <= slack for n, d in planes):
                        if not any(length(sub(p, q)) <= slack for q in out):
                            out.append(p)
        return out

    def margin(self, c, p):
        """How far `p` lies inside cell `c` (negative outside)."""
        return min(d - dot(n, p) for n, d in self.cells[c]["planes"])

    def outside_all(self, p):
        for i, c in enumerate(self.cells):
            if all(c["min"][k] - self.tol * 2 <= p[k] <= c["max"][k] + self.tol * 2 for k in range(3)):
                if self.margin(i, p) >= -self.tol * 2:
                    return False
        return True

    def face(self, c, plane):
        """The corners of cell `c` on `plane`, and their mean."""
        n, d = plane
        slack = max(self.tol, 1e-9) * 4
        pts = [p for p in self.cells[c]["corners"] if abs(dot(n, p) - d) <= slack]
        return pts, (mean(pts) if len(pts) >= 3 else None)

    def pairs(self):
        """One portal of each opening: the lower index of a portal and its partner."""
        return [p for p in self.portals if p["partner"] is None or p["partner"] >= p["index"]]


def solve3(a, b, c):
    (n1, d1), (n2, d2), (n3, d3) = a, b, c
    det = dot(n1, cross(n2, n3))
    if abs(det) < 1e-9:
        return None
    p = add(add(mul(cross(n2, n3), d1), mul(cross(n3, n1), d2)), mul(cross(n1, n2), d3))
    return mul(p, 1.0 / det)


# --- cameras -------------------------------------------------------------------------------


def num(x):
    r = round(x, 10)
    if r == 0:
        r = 0.0
    if r == int(r) and abs(r) < 1e15:
        return float(int(r))
    return r


def camera(eye, look, view=V0):
    look = unit(look)
    up = [0.0, 1.0, 0.0]
    if abs(look[1]) > 0.999:
        up = [0.0, 0.0, -1.0]
    fov, aspect, near = view
    return {
        "eye": [num(x) for x in eye],
        "look": [num(x) for x in look],
        "up": up,
        "fov_y": fov,
        "aspect": num(aspect),
        "near": near,
    }


AXES = [("+x", [1.0, 0.0, 0.0]), ("-x", [-1.0, 0.0, 0.0]), ("+z", [0.0, 0.0, 1.0]), ("-z", [0.0, 0.0, -1.0])]


def centres(lv, cells):
    out = []
    for c in cells:
        for name, d in AXES:
            out.append((camera(lv.cells[c]["inner"], d), f"centre: cell {c}, looking {name}"))
    return out


def shared_faces(lv):
    """(cell i, cell j, plane of i) for every two cells with coincident opposite planes whose
    faces touch."""
    tol = max(lv.tol, 1e-9)
    out = []
    n = len(lv.cells)
    for i in range(n):
        a = lv.cells[i]
        for j in range(i + 1, n):
            b = lv.cells[j]
            if any(a["min"][k] > b["max"][k] + tol * 4 or b["min"][k] > a["max"][k] + tol * 4 for k in range(3)):
                continue
            for pa in a["planes"]:
                for pb in b["planes"]:
                    if dot(pa[0], pb[0]) < -1 + 1e-9 and abs(pa[1] + pb[1]) <= tol * 4:
                        out.append((i, j, pa))
    return out


def face_points(lv, i, j, plane):
    """Points exactly on the face cells `i` and `j` share: each face's centroid and their mean,
    those on both cells' boundaries."""
    _, ci = lv.face(i, plane)
    _, cj = lv.face(j, (mul(plane[0], -1.0), -plane[1]))
    cands = [p for p in (ci, cj) if p is not None]
    if len(cands) == 2:
        cands.append(mean(cands))
    out = []
    for p in cands:
        if lv.margin(i, p) >= -lv.tol / 2 and lv.margin(j, p) >= -lv.tol / 2:
            if not any(length(sub(p, q)) < 1e-6 for q in out):
                out.append(p)
    return out


def faces(lv, limit=None):
    out = []
    found = shared_faces(lv)
    if limit is not None:
        found = spread(found, max(1, limit // 2))
    for i, j, plane in found:
        n = plane[0]
        t = tangent(n)
        for k, p in enumerate(face_points(lv, i, j, plane)):
            looks = [("across into " + str(j), n), ("across into " + str(i), mul(n, -1.0)), ("along it", t)]
            if limit is not None:
                looks = looks[:1] if k == 0 else looks[1:2]
            for what, d in looks:
                out.append((camera(p, d), f"face: on the face cells {i} and {j} share, point {k}, looking {what}"))
    return out


def hints(lv, limit=None):
    """The location hint: an eye on a face two cells share is in the cell the previous camera
    was in. Each face's first point, reached from the middle of one cell, then of the other."""
    out = []
    found = shared_faces(lv)
    if limit is not None:
        found = spread(found, limit)
    for i, j, plane in found:
        points = face_points(lv, i, j, plane)
        if not points:
            continue
        n = plane[0]
        for before, look in [(j, n), (i, mul(n, -1.0))]:
            out.append((camera(lv.cells[before]["inner"], look), f"hint: cell {before}'s middle, before the next"))
            out.append(
                (camera(points[0], look), f"hint: on the face cells {i} and {j} share, after a camera in cell {before}")
            )
    return out


def edges(poly, most):
    """Up to `most` edges of `poly`, spread over it."""
    all_ = [(poly[k], poly[(k + 1) % len(poly)]) for k in range(len(poly))]
    return spread(all_, most)


def portal_cams(lv, portals, edge_count=4, small=False):
    out = []
    for p in portals:
        c, n, i = p["centre"], p["n"], p["index"]
        t = tangent(n)
        r = near_radius(V0) + lv.tol
        looks = [("into its target", n), ("back into its source", mul(n, -1.0)), ("along it", t)]
        for what, d in looks[:2] if small else looks:
            out.append((camera(c, d), f"portal: portal {i}'s centroid, looking {what}"))
        for e, (a, b) in enumerate(edges(p["poly"], 1 if small else edge_count)):
            m = mul(add(a, b), 0.5)
            o = unit(cross(sub(b, a), n))
            if o is None:
                continue
            if dot(o, sub(m, c)) < 0:
                o = mul(o, -1.0)
            offsets = [
                ("1 mm inside the edge", -1e-3),
                ("on the edge", 0.0),
                ("beyond the edge by the near plane's reach less a hair", r - HAIR),
                ("beyond the edge by the near plane's reach and a hair", r + HAIR),
            ]
            if small:
                offsets = offsets[1:3]
            for what, s in offsets:
                eye = add(m, mul(o, s))
                out.append((camera(eye, n), f"portal: portal {i}, edge {e}, {what}, looking into its target"))
                if not small:
                    out.append((camera(eye, mul(o, -1.0)), f"portal: portal {i}, edge {e}, {what}, looking across it"))
    return out


def reach_cams(lv, portals, small=False):
    out = []
    for p in portals:
        c, n, i = p["centre"], p["n"], p["index"]
        t = tangent(n)
        for view in [V0] if small else [V0, V1]:
            r = near_radius(view)
            dists = [
                ("the near plane's reach less a hair", r - HAIR),
                ("the near plane's reach and a hair", r + HAIR),
                ("the near plane's reach and the tolerance and a hair", r + lv.tol + HAIR),
                ("half the tolerance", lv.tol / 2),
            ]
            if small:
                dists = dists[:2]
            for side, sign in [("source", 1.0), ("target", -1.0)]:
                for what, s in dists:
                    eye = sub(c, mul(n, sign * s))
                    toward = mul(n, sign)
                    looks = [("at it", toward), ("away from it", mul(toward, -1.0)), ("along it", t)]
                    if small:
                        looks = looks[:2] if side == "source" else looks[1:2]
                    for look, d in looks:
                        out.append(
                            (
                                camera(eye, d, view),
                                f"reach: {what} ({s:.9f} m) from portal {i} on its {side} side, "
                                f"looking {look}, fov {view[0]:g}, near {view[2]:g}",
                            )
                        )
    return out


def transform_cams(lv):
    out = []
    for p in lv.portals:
        if p["kind"] == "plain":
            continue
        c, n, i = p["centre"], p["n"], p["index"]
        t = tangent(n)
        for dist in [0.5, 1.5, 3.0]:
            eye = sub(c, mul(n, dist))
            for turn in [0, 35, -35]:
                out.append(
                    (camera(eye, yaw(n, turn)), f"transform: {p['kind']} portal {i}, {dist} m in front, turned {turn} degrees")
                )
            out.append((camera(eye, pitch(n, -20)), f"transform: {p['kind']} portal {i}, {dist} m in front, looking down 20 degrees"))
        for side in [1.0, -1.0]:
            eye = add(sub(c, mul(n, 1.5)), mul(t, side * 1.2))
            out.append((camera(eye, sub(c, eye)), f"transform: {p['kind']} portal {i}, from the side, looking at its centre"))
            out.append(
                (camera(eye, sub(c, eye), V1), f"transform: {p['kind']} portal {i}, from the side, looking at its centre, fov 90")
            )
        r = near_radius(V0) + lv.tol
        for what, s in [("the near plane's reach less a hair", r - HAIR), ("the near plane's reach and a hair", r + HAIR)]:
            eye = sub(c, mul(n, s))
            out.append((camera(eye, n), f"transform: {p['kind']} portal {i}, {what} in front, looking at it"))
            out.append((camera(eye, t), f"transform: {p['kind']} portal {i}, {what} in front, looking along it"))
    return out


def outside_cams(lv, wall_limit=None):
    out = []
    if not lv.cells:
        return out
    centre = mean([lv.lo, lv.hi])
    half = mul(sub(lv.hi, lv.lo), 0.5)
    for name, d in AXES + [("-y", [0.0, -1.0, 0.0])]:
        # Beyond the bounds by 2 m (above, for -y), looking back at the middle.
        eye = sub(centre, [d[k] * (half[k] + 2.0) for k in range(3)])
        out.append((camera(eye, d), f"outside: beyond the level's bounds, looking {name} at its middle"))
    for p in lv.portals:
        if p["to"] is not None:
            continue
        c, n, i = p["centre"], p["n"], p["index"]
        r = near_radius(V0) + lv.tol
        for what, s in [("1 m", 1.0), ("3 m", 3.0), ("the near plane's reach less a hair", r - HAIR), ("the near plane's reach and a hair", r + HAIR)]:
            eye = add(c, mul(n, s))
            out.append((camera(eye, mul(n, -1.0)), f"outside: {what} outside exterior opening {i}, looking in"))
            if wall_limit is not None:
                break
    walls = []
    r = near_radius(V0) + lv.tol
    cells = list(range(len(lv.cells)))
    if wall_limit is not None:
        cells = spread(cells, wall_limit * 2)
    for ci in cells:
        for k, plane in enumerate(lv.cells[ci]["planes"]):
            _, f = lv.face(ci, plane)
            if f is None:
                continue
            n = plane[0]
            for what, s in [
                ("the near plane's reach less a hair", r - HAIR),
                ("the near plane's reach and a hair", r + HAIR),
                ("0.1 m", 0.1),
            ]:
                eye = add(f, mul(n, s))
                if lv.outside_all(eye):
                    walls.append((ci, k, what, eye, n))
    if wall_limit is not None:
        walls = spread(walls, wall_limit)
    for ci, k, what, eye, n in walls:
        out.append((camera(eye, mul(n, -1.0)), f"outside: {what} outside cell {ci}'s face {k}, looking at it"))
        if wall_limit is None:
            out.append((camera(eye, tangent(n)), f"outside: {what} outside cell {ci}'s face {k}, looking along it"))
    return out


def spread(items, most):
    """At most `most` of `items`, evenly spaced, in order."""
    if most >= len(items):
        return list(items)
    return [items[(k * len(items)) // most] for k in range(most)]


def cameras_for(lv, wanted):
    if wanted is None:
        cams = centres(lv, range(len(lv.cells)))
        cams += faces(lv)
        cams += hints(lv)
        cams += portal_cams(lv, lv.pairs())
        cams += reach_cams(lv, lv.pairs())
        cams += transform_cams(lv)
        cams += outside_cams(lv)
        return cams
    # A big level: a few of each kind, the rest cell centres.
    pairs = lv.pairs()
    cams = faces(lv, limit=20)[:20]
    cams += hints(lv, limit=3)[:12]
    cams += portal_cams(lv, spread(pairs, 10), small=True)[:40]
    cams += reach_cams(lv, spread(pairs[1::2], 8), small=True)[:40]
    cams += transform_cams(lv)[:10]
    cams += outside_cams(lv, wall_limit=16)[:30]
    rest = wanted - len(cams)
    cells = spread(list(range(len(lv.cells))), max(0, (rest + 3) // 4))
    cams += centres(lv, cells)
    return cams[:wanted]


# --- writing -------------------------------------------------------------------------------


def convert(level, args, out):
    cmd = [EXE, "convert", str(ROOT / level), "-o", str(out)] + args
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if not out.exists():
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stderr.decode(errors='replace')}")


def main():
    if not Path(EXE).exists():
        sys.exit(f"{EXE} is missing: run `cargo build --release` first, or set $PORTCULLIS")
    samples = sorted(
        str(p.relative_to(ROOT)) for p in list((ROOT / "samples").glob("*.gltf")) + list((ROOT / "samples").glob("*.map"))
    )
    levels = [(s, [], None) for s in samples] + SHARED
    OUT.mkdir(parents=True, exist_ok=True)
    cases = []
    total = 0
    with tempfile.TemporaryDirectory() as tmp:
        for level, args, wanted in levels:
            if not (ROOT / level).exists():
                sys.exit(f"{level} is missing: the shared levels are needed to write every case")
            name = Path(level).stem
            glb = Path(tmp) / f"{name}.glb"
            convert(level, args, glb)
            lv = Level(read_extension(glb))
            cams = cameras_for(lv, wanted)
            total += len(cams)
            (OUT / f"{name}.cameras.jsonl").write_text(
                "".join(json.dumps(c, separators=(",", ":")) + "\n" for c, _ in cams)
            )
            (OUT / f"{name}.labels.txt").write_text("".join(label + "\n" for _, label in cams))
            runs = [[]] + [sum((["--closed", str(p)] for p in ps), []) for ps in DOORS.get(level, [])]
            for extra in runs:
                suffix = "".join("-closed-" + x for x in extra if x != "--closed")
                cases.append(
                    {
                        "name": name + suffix,
                        "level": level,
                        "convert": args,
                        "cameras": f"{name}.cameras.jsonl",
                        "labels": f"{name}.labels.txt",
                        "cull": extra,
                        "expected": f"{name}{suffix}.expected.jsonl",
                    }
                )
            print(f"{level}: {len(lv.cells)} cells, {len(lv.portals)} portals, {len(cams)} cameras", file=sys.stderr)
    manifest = {
        "about": (
            "Test vectors for the portcullis runtime (docs/guide.md, 'Test vectors'). Per case: "
            "convert `level` (relative to the repository root) with `portcullis convert LEVEL -o "
            "X.glb CONVERT...`, run `cull X.glb --cameras CAMERAS CULL... --draw-lists` (portcullis "
            "itself with --format jsonl), and compare each line with `expected` (paths relative "
            "to this file), `stats` left out. Cameras are traced in order, each with the previous "
            "camera's cell as the hint. Written by scripts/make_vectors.py; expected files by "
            "PORTCULLIS_BLESS=1 cargo test --test vectors."
        ),
        "cases": cases,
    }
    (OUT / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")
    print(f"{len(cases)} cases, {total} cameras in {len(levels)} files", file=sys.stderr)


if __name__ == "__main__":
    main()
