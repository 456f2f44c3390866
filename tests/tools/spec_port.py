#!/usr/bin/env python3
"""An independent port of the portcullis frame-time runtime, written from the spec's text alone
(schemas/PORTCULLIS_portals.md, "Runtime rules (for ports)", and the guide's engine section,
without reading the Rust or JavaScript runtimes), Python 3 standard library only. It is the
evidence that the spec is enough to port from: scripts/test.sh checks it against the test
vectors (scripts/check_vectors.py), as it does the JavaScript port and the Bevy plugin. Where
it needed a rule the text did not state, the text was fixed (the changelog says which).

    python3 port.py cull LEVEL.glb --cameras CAMERAS.jsonl [--closed N ...] [--open N ...]
                    [--no-pvs] [--max-depth N] [--transform-depth N] [--draw-lists]
                    [--format jsonl]
"""
import base64
import json
import math
import os
import struct
import sys

EPS = 1e-9
PINCH = 1e-6


class Refused(Exception):
    pass


# ---------------------------------------------------------------- vectors

def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def mul(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def length(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def normalize(a):
    l = length(a)
    return (a[0] / l, a[1] / l, a[2] / l)


def mean(pts):
    sx = sy = sz = 0.0
    for p in pts:
        sx += p[0]
        sy += p[1]
        sz += p[2]
    n = len(pts)
    return (sx / n, sy / n, sz / n)


def clamp(x, lo, hi):
    return lo if x < lo else hi if x > hi else x


def dist(h, p):
    n = h[0]
    return n[0] * p[0] + n[1] * p[1] + n[2] * p[2] - h[1]


def flipped(h):
    n = h[0]
    return ((-n[0], -n[1], -n[2]), -h[1])


def clip(poly, h, eps):
    """Rule 2: the convex polygon's part with dist(h, .) <= eps, same winding."""
    out = []
    a = poly[-1]
    da = dist(h, a)
    for b in poly:
        db = dist(h, b)
        ina = da <= eps
        if ina:
            out.append(a)
        if ina != (db <= eps):
            t = clamp((da - eps) / (da - db), 0.0, 1.0)
            out.append((a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t,
                        a[2] + (b[2] - a[2]) * t))
        a, da = b, db
    return out


def newell(poly):
    p0 = poly[0]
    sx = sy = sz = 0.0
    m = len(poly)
    for i in range(m):
        a = sub(poly[i], p0)
        b = sub(poly[(i + 1) % m], p0)
        c = cross(a, b)
        sx += c[0]
        sy += c[1]
        sz += c[2]
    return (sx, sy, sz)


def distance_to_polygon(p, poly, n):
    height = dot(sub(p, poly[0]), n)
    q = sub(p, mul(n, height))
    orient = 1.0 if dot(newell(poly), n) >= 0 else -1.0
    m = len(poly)
    inside = m >= 3
    if inside:
        for i in range(m):
            a = poly[i]
            b = poly[(i + 1) % m]
            if dot(cross(sub(b, a), sub(q, a)), n) * orient < 0:
                inside = False
                break
    if inside:
        return abs(height)
    best = None
    for i in range(m):
        a = poly[i]
        b = poly[(i + 1) % m]
        ab = sub(b, a)
        l2 = dot(ab, ab)
        t = 0.0 if l2 == 0 else clamp(dot(sub(p, a), ab) / l2, 0.0, 1.0)
        d = length(sub(p, add(a, mul(ab, t))))
        if best is None or d < best:
            best = d
    return best


# ---------------------------------------------------------------- matrices (column-major)

IDENTITY = (1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0)


def mat_mul(a, b):
    out = [0.0] * 16
    for c in range(4):
        for r in range(4):
            s = 0.0
            for k in range(4):
                s += a[4 * k + r] * b[4 * c + k]
            out[4 * c + r] = s
    return tuple(out)


def mat_point(m, p):
    x, y, z = p
    return (m[0] * x + m[4] * y + m[8] * z + m[12],
            m[1] * x + m[5] * y + m[9] * z + m[13],
            m[2] * x + m[6] * y + m[10] * z + m[14])


def cofactors(m):
    """The 2x2 minors of a column-major 4x4 matrix's top and bottom row pairs, and its rows."""
    a = [[m[4 * c + r] for c in range(4)] for r in range(4)]
    s = [a[0][i] * a[1][j] - a[1][i] * a[0][j] for i, j in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))]
    c = [a[2][i] * a[3][j] - a[3][i] * a[2][j] for i, j in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))]
    return a, s, c


def mat_det(m):
    _, s, c = cofactors(m)
    return s[0] * c[5] - s[1] * c[4] + s[2] * c[3] + s[3] * c[2] - s[4] * c[1] + s[5] * c[0]


def mat_inv(m):
    a, s, c = cofactors(m)
    s0, s1, s2, s3, s4, s5 = s
    c0, c1, c2, c3, c4, c5 = c
    det = mat_det(m)
    inv = 1.0 / det
    b = [[0.0] * 4 for _ in range(4)]
    b[0][0] = (a[1][1] * c5 - a[1][2] * c4 + a[1][3] * c3) * inv
    b[0][1] = (-a[0][1] * c5 + a[0][2] * c4 - a[0][3] * c3) * inv
    b[0][2] = (a[3][1] * s5 - a[3][2] * s4 + a[3][3] * s3) * inv
    b[0][3] = (-a[2][1] * s5 + a[2][2] * s4 - a[2][3] * s3) * inv
    b[1][0] = (-a[1][0] * c5 + a[1][2] * c2 - a[1][3] * c1) * inv
    b[1][1] = (a[0][0] * c5 - a[0][2] * c2 + a[0][3] * c1) * inv
    b[1][2] = (-a[3][0] * s5 + a[3][2] * s2 - a[3][3] * s1) * inv
    b[1][3] = (a[2][0] * s5 - a[2][2] * s2 + a[2][3] * s1) * inv
    b[2][0] = (a[1][0] * c4 - a[1][1] * c2 + a[1][3] * c0) * inv
    b[2][1] = (-a[0][0] * c4 + a[0][1] * c2 - a[0][3] * c0) * inv
    b[2][2] = (a[3][0] * s4 - a[3][1] * s2 + a[3][3] * s0) * inv
    b[2][3] = (-a[2][0] * s4 + a[2][1] * s2 - a[2][3] * s0) * inv
    b[3][0] = (-a[1][0] * c3 + a[1][1] * c1 - a[1][2] * c0) * inv
    b[3][1] = (a[0][0] * c3 - a[0][1] * c1 + a[0][2] * c0) * inv
    b[3][2] = (-a[3][0] * s3 + a[3][1] * s1 - a[3][2] * s0) * inv
    b[3][3] = (a[2][0] * s3 - a[2][1] * s1 + a[2][2] * s0) * inv
    out = [0.0] * 16
    for r in range(4):
        for c in range(4):
            out[4 * c + r] = b[r][c]
    return tuple(out)


# ---------------------------------------------------------------- loading

def load_gltf(path):
    with open(path, "rb") as f:
        data = f.read()
    bin_chunk = None
    if data[:4] == b"glTF":
        _magic, _version, total = struct.unpack_from("<III", data, 0)
        off = 12
        js = None
        while off + 8 <= min(total, len(data)):
            clen, ctype = struct.unpack_from("<II", data, off)
            chunk = data[off + 8:off + 8 + clen]
            if ctype == 0x4E4F534A:
                js = json.loads(chunk.decode("utf-8"))
            elif ctype == 0x004E4942 and bin_chunk is None:
                bin_chunk = chunk
            off += 8 + clen
        if js is None:
            raise Refused("no JSON chunk")
    else:
        js = json.loads(data.decode("utf-8"))
    base = os.path.dirname(os.path.abspath(path))

    cache = {}

    def buffer_bytes(i):
        if i in cache:
            return cache[i]
        b = js["buffers"][i]
        uri = b.get("uri")
        if uri is None:
            raw = bin_chunk
        elif uri.startswith("data:"):
            raw = base64.b64decode(uri.split(",", 1)[1])
        else:
            from urllib.parse import unquote
            with open(os.path.join(base, unquote(uri)), "rb") as f:
                raw = f.read()
        cache[i] = raw
        return raw

    def view_bytes(v):
        bv = js["bufferViews"][v]
        raw = buffer_bytes(bv["buffer"])
        off = bv.get("byteOffset", 0)
        return raw[off:off + bv["byteLength"]]

    return js, view_bytes


class Cell:
    __slots__ = ("planes", "bmin", "bmax", "priority", "faces", "volume", "overlapped",
                 "nodes", "draws", "brange")


class Portal:
    __slots__ = ("polygon", "source", "target", "one_way", "closed", "transform", "inverse",
                 "det", "partner", "plane", "exterior")


class Level:
    def __init__(self, path):
        js, view_bytes = load_gltf(path)
        ext = (js.get("extensions") or {}).get("PORTCULLIS_portals")
        if ext is None:
            raise Refused("CULL_NOT_CONVERTED: the level has no PORTCULLIS_portals extension")
        tol = float(ext["tolerance"])
        if not (math.isfinite(tol) and tol > 0):
            raise Refused("bad tolerance")
        self.tol = tol
        self.cells = []
        for c in ext.get("cells", []):
            cell = Cell()
            planes = []
            for a, b, cc, d in c["planes"]:
                L = math.sqrt(a * a + b * b + cc * cc)
                if not (math.isfinite(L) and L > 0.5):
                    raise Refused("bad plane")
                planes.append(((a / L, b / L, cc / L), d / L))
            cell.planes = planes
            cell.bmin = tuple(float(x) for x in c["bounds"]["min"])
            cell.bmax = tuple(float(x) for x in c["bounds"]["max"])
            if any(cell.bmin[i] > cell.bmax[i] for i in range(3)):
                raise Refused("bad bounds")
            cell.priority = c.get("priority", 0)
            cell.nodes = c.get("nodes", [])
            cell.draws = c.get("draws", [])
            self.cells.append(cell)
        N = self.N = len(self.cells)
        for cell in self.cells:
            self._faces(cell)
            if not cell.faces:
                raise Refused("cell of no faces")
        for i, ci in enumerate(self.cells):
            ci.overlapped = False
            for j, cj in enumerate(self.cells):
                if i == j:
                    continue
                o = min(min(ci.bmax[a], cj.bmax[a]) - max(ci.bmin[a], cj.bmin[a]) for a in range(3))
                if o > tol:
                    ci.overlapped = True
                    break
        self.portals = []
        for p in ext.get("portals", []):
            po = Portal()
            po.polygon = [tuple(float(x) for x in c) for c in p["polygon"]]
            if len(po.polygon) < 3:
                raise Refused("polygon of fewer than 3 corners")
            cs = p["cells"]
            po.source = cs[0]
            po.target = cs[1] if len(cs) > 1 else None
            po.exterior = len(cs) == 1
            for c in cs:
                if not (0 <= c < N):
                    raise Refused("cell index out of range")
            po.one_way = bool(p.get("oneWay", False))
            po.closed = bool(p.get("closed", False))
            po.partner = p.get("partner")
            nw = newell(po.polygon)
            if nw == (0.0, 0.0, 0.0):
                raise Refused("polygon of no area")
            n = normalize((-nw[0], -nw[1], -nw[2]))
            po.plane = (n, dot(n, mean(po.polygon)))
            t = p.get("transform")
            if t is not None:
                # rule 11 tests `p.transform` (present), so a present identity still counts as
                # a transformed portal; convert never writes one (absent means identity)
                t = tuple(float(x) for x in t)
            po.transform = t
            if t is not None:
                det = mat_det(t)
                if not math.isfinite(det) or abs(det) <= 1e-12:
                    raise Refused("bad transform")
                po.det = det
                po.inverse = mat_inv(t)
            else:
                po.det = 1.0
                po.inverse = None
            self.portals.append(po)
        for i, p in enumerate(self.portals):
            if p.partner is not None:
                if not (0 <= p.partner < len(self.portals)):
                    raise Refused("partner out of range")
                q = self.portals[p.partner]
                if q.partner != i:
                    raise Refused("partners do not name each other")
        # links, rule 3: (portal, to, reversed, plane)
        self.links = [[] for _ in range(N + 1)]
        for i, p in enumerate(self.portals):
            self.links[p.source].append((i, p.target if p.target is not None else N, False,
                                         p.plane))
            if p.exterior and not p.one_way:
                self.links[N].append((i, p.source, True, flipped(p.plane)))
        # PVS, rule 4
        self.pvs = None
        vis = ext.get("visibility")
        if vis is not None:
            enc = vis.get("encoding")
            if enc == "lists":
                rows = vis["lists"]
                if len(rows) != N:
                    raise Refused("PVS rows")
                self.pvs = [set(r) for r in rows]
            else:
                rb = vis["rowBytes"]
                raw = view_bytes(vis["bufferView"])
                want = N * rb
                if enc == "bitsZeroRun":
                    out = bytearray()
                    i = 0
                    while len(out) < want and i < len(raw):
                        b = raw[i]
                        if b != 0:
                            out.append(b)
                            i += 1
                        else:
                            k = raw[i + 1] if i + 1 < len(raw) else 0
                            out.extend(b"\0" * k)
                            i += 2
                    raw = bytes(out[:want])
                if len(raw) < want:
                    raise Refused("PVS too short")
                self.pvs = []
                for c in range(N):
                    row = raw[c * rb:(c + 1) * rb]
                    self.pvs.append({j for j in range(N) if row[j >> 3] >> (j & 7) & 1})
        # split
        split = ext.get("split")
        self.split_prims = split["primitives"] if split else []
        self.split_nodes = {sp["node"] for sp in self.split_prims}
        self._grid()

    def _faces(self, cell):
        tol = self.tol
        mn, mx = cell.bmin, cell.bmax
        size = max(length(sub(mx, mn)), tol) * 2
        centre = ((mn[0] + mx[0]) / 2, (mn[1] + mx[1]) / 2, (mn[2] + mx[2]) / 2)
        faces = []
        planes = cell.planes
        for k, h in enumerate(planes):
            n = h[0]
            o = sub(centre, mul(n, dist(h, centre)))
            helper = (1.0, 0.0, 0.0) if abs(n[0]) < 0.6 else (0.0, 1.0, 0.0)
            u = mul(normalize(cross(n, helper)), size)
            v = cross(n, u)
            poly = [sub(sub(o, u), v), sub(add(o, u), v), add(add(o, u), v), add(sub(o, u), v)]
            for j, g in enumerate(planes):
                if j != k:
                    poly = clip(poly, g, tol)
                    if not poly:
                        break
            if len(poly) >= 3:
                faces.append((poly, h))
        cell.faces = faces
        if faces:
            inner = mean([c for poly, _h in faces for c in poly])
            vol = 0.0
            for poly, h in faces:
                vol += abs(dot(newell(poly), h[0])) / 2 * (h[1] - dot(h[0], inner)) / 3
            cell.volume = abs(vol)
        else:
            cell.volume = 0.0

    def _grid(self):
        tol = self.tol
        N = self.N
        if N == 0:
            return
        lo = [min(c.bmin[a] for c in self.cells) - tol for a in range(3)]
        hi = [max(c.bmax[a] for c in self.cells) + tol for a in range(3)]
        extent = [max(hi[a] - lo[a], tol) for a in range(3)]
        x = N / (extent[0] * extent[1] * extent[2])
        k = cbrt(x)
        dims = [int(clamp(math.ceil(e * k), 1, 256)) for e in extent]
        size = [extent[a] / dims[a] for a in range(3)]
        self.g_lo, self.g_dims, self.g_size = lo, dims, size
        for c in self.cells:
            b0 = self.bucket((c.bmin[0] - tol, c.bmin[1] - tol, c.bmin[2] - tol))
            b1 = self.bucket((c.bmax[0] + tol, c.bmax[1] + tol, c.bmax[2] + tol))
            c.brange = (b0, b1)

    def bucket(self, p):
        out = []
        for a in range(3):
            v = (p[a] - self.g_lo[a]) / self.g_size[a]
            if v != v:
                b = 0
            elif v >= 1e18:
                b = self.g_dims[a] - 1
            elif v <= -1e18:
                b = 0
            else:
                b = min(max(math.floor(v), 0), self.g_dims[a] - 1)
            out.append(b)
        return tuple(out)

    def bucket_cells(self, p):
        if self.N == 0:
            return []
        b = self.bucket(p)
        out = []
        for i, c in enumerate(self.cells):
            b0, b1 = c.brange
            if b0[0] <= b[0] <= b1[0] and b0[1] <= b[1] <= b1[1] and b0[2] <= b[2] <= b1[2]:
                out.append(i)
        return out

    def margin(self, c, p):
        m = None
        for n, d in self.cells[c].planes:
            v = d - (n[0] * p[0] + n[1] * p[1] + n[2] * p[2])
            if m is None or v < m:
                m = v
        return m

    def locate(self, p, hint):
        tol = self.tol
        if hint is not None and not self.cells[hint].overlapped and self.margin(hint, p) > tol:
            return ("inside", hint)
        inside = boundary = None
        for c in self.bucket_cells(p):
            m = self.margin(c, p)
            if m > tol:
                if inside is None or (self.cells[c].priority, -self.cells[c].volume) > \
                        (self.cells[inside].priority, -self.cells[inside].volume):
                    inside = c
            elif m >= -tol:
                if boundary is None or (boundary != hint and c == hint):
                    boundary = c
        if inside is not None:
            return ("inside", inside)
        if boundary is not None:
            return ("boundary", boundary)
        return ("outside", self.nearest_cell(p))

    def nearest_cell(self, p):
        best = None
        for i, c in enumerate(self.cells):
            e = [max(c.bmin[a] - p[a], p[a] - c.bmax[a], 0.0) for a in range(3)]
            bound = length(e)
            if best is not None and bound >= best[1]:
                continue
            d = None
            for poly, h in c.faces:
                if dist(h, p) > 0:
                    x = distance_to_polygon(p, poly, h[0])
                    if d is None or x < d:
                        d = x
            if d is None:
                d = 0.0
            if best is None or d < best[1]:
                best = (i, d)
        return best


def cbrt(x):
    if x <= 0:
        return 0.0
    y = x ** (1.0 / 3.0)
    y = y - (y * y * y - x) / (3 * y * y)
    return y


# ---------------------------------------------------------------- camera

CAMERA_KEYS = {"eye", "look", "up", "fov_y", "aspect", "near"}


class Camera:
    def __init__(self, obj, tol):
        if not isinstance(obj, dict) or set(obj) - CAMERA_KEYS or "eye" not in obj \
                or "look" not in obj:
            raise Refused("CULL_CAMERA_INVALID")
        self.eye = tuple(float(x) for x in obj["eye"])
        look = tuple(float(x) for x in obj["look"])
        up = tuple(float(x) for x in obj.get("up", [0.0, 1.0, 0.0]))
        fov_y = float(obj.get("fov_y", 60.0))
        aspect = float(obj.get("aspect", 16.0 / 9.0))
        near = float(obj.get("near", 0.05))
        if not all(math.isfinite(x) for x in self.eye) or length(look) == 0:
            raise Refused("CULL_CAMERA_INVALID")
        if not (0 < fov_y < 180 and aspect > 0 and near > 0):
            raise Refused("CULL_CAMERA_INVALID")
        f = normalize(look)
        rr = cross(f, up)
        if length(rr) == 0:
            raise Refused("CULL_CAMERA_INVALID")
        r = normalize(rr)
        u = cross(r, f)
        self.f, self.r, self.u = f, r, u
        tan_y = math.tan(math.radians(fov_y) / 2)
        tan_x = tan_y * aspect
        self.tan_x, self.tan_y = tan_x, tan_y
        self.near = near
        self.near_plane = ((-f[0], -f[1], -f[2]), -dot(f, self.eye) - near)
        self.R = near * math.sqrt(1 + tan_x * tan_x + tan_y * tan_y) + tol


# ---------------------------------------------------------------- 2D

def cross2(o, a, b):
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def area2(q):
    s = 0.0
    m = len(q)
    for i in range(m):
        a = q[i]
        b = q[(i + 1) % m]
        s += a[0] * b[1] - b[0] * a[1]
    return s


def perimeter(q):
    s = 0.0
    m = len(q)
    for i in range(m):
        a = q[i]
        b = q[(i + 1) % m]
        s += math.hypot(b[0] - a[0], b[1] - a[1])
    return s


def clip2(q, a, b, eps):
    ex, ey = b[0] - a[0], b[1] - a[1]
    slack = eps * math.hypot(ex, ey)

    def side(x):
        return cross2(a, b, x) + slack
    out = []
    p = q[-1]
    sp = side(p)
    for x in q:
        sx = side(x)
        if sp >= 0:
            out.append(p)
        if (sp >= 0) != (sx >= 0):
            t = clamp(sp / (sp - sx), 0.0, 1.0)
            out.append((p[0] + (x[0] - p[0]) * t, p[1] + (x[1] - p[1]) * t))
        p, sp = x, sx
    return out


def clip_screen(fpoly, P, q):
    xs = [c[0] for c in q]
    ys = [c[1] for c in q]
    if min(xs) > P[2] + EPS or max(xs) < P[0] - EPS or min(ys) > P[3] + EPS \
            or max(ys) < P[1] - EPS:
        return None
    if area2(q) < 0:
        q = q[::-1]
    m = len(fpoly)
    for i in range(m):
        a = fpoly[i]
        b = fpoly[(i + 1) % m]
        if all(cross2(a, b, x) >= -EPS for x in q):
            continue
        q = clip2(q, a, b, EPS)
        if len(q) < 3:
            return None
    if area2(q) <= PINCH * perimeter(q):
        return None
    xs = [c[0] for c in q]
    ys = [c[1] for c in q]
    rect = (max(min(xs), P[0]), max(min(ys), P[1]), min(max(xs), P[2]), min(max(ys), P[3]))
    if rect[0] > rect[2] or rect[1] > rect[3]:
        return None
    return q, rect


# ---------------------------------------------------------------- trace

SCREEN = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
SCREEN_RECT = (-1.0, -1.0, 1.0, 1.0)

STAT_KEYS = ["entered", "portals_tested", "portals_culled", "pvs_skipped", "closed_skipped",
             "on_path_skipped", "passed_through", "depth_limit_hits", "transform_limit_hits",
             "deepest"]


class View:
    __slots__ = ("polygon", "clips", "rect")

    def __init__(self, polygon, clips, rect):
        self.polygon, self.clips, self.rect = polygon, clips, rect


class Frame:
    __slots__ = ("region", "cell", "view", "depth", "transforms", "D", "D_inv", "mirrored")


class Entry:
    __slots__ = ("cell", "rect", "depth", "via", "D", "mirrored")


class Tracer:
    def __init__(self, level, closed, use_pvs=True, max_depth=32, max_transform_depth=2):
        self.level = level
        self.closed = closed
        self.use_pvs = use_pvs
        self.max_depth = max_depth
        self.max_transform_depth = max_transform_depth
        self.hint = None

    def root(self, region, cam):
        fr = Frame()
        fr.region = region
        fr.cell = region if region < self.level.N else None
        fr.view = View(SCREEN, [cam.near_plane], SCREEN_RECT)
        fr.depth = 0
        fr.transforms = 0
        fr.D = None
        fr.D_inv = None
        fr.mirrored = False
        return fr

    def trace(self, cam):
        L = self.level
        N = L.N
        tol = L.tol
        self.cam = cam
        eye = cam.eye
        R = cam.R
        loc = L.locate(eye, self.hint)
        kind, val = loc
        self.stats = dict.fromkeys(STAT_KEYS, 0)
        if kind in ("inside", "boundary"):
            region = val
            self.hint = val
        else:
            region = N
            self.hint = None
        self.pvs_row = val if (kind == "inside" and L.pvs is not None and self.use_pvs) else None
        self.outside_links = [l for l in L.links[N] if -dist(l[3], eye) >= -R]
        self.visible = []
        self.direct = {}
        self.on_path_cells = [False] * N
        self.path = []
        self.passed = {}
        self.walk(self.root(region, cam))
        if kind == "boundary":
            walked = {val}
            for k in L.bucket_cells(eye):
                if k in walked:
                    continue
                if L.margin(k, eye) >= -tol:
                    walked.add(k)
                    self.pvs_row = None
                    self.walk(self.root(k, cam))
        if kind == "outside":
            self.walk_nearby(val, cam)
        return loc

    def walk_nearby(self, nearest, cam):
        L = self.level
        eye = cam.eye
        R = cam.R
        roots = []
        if nearest is not None:
            c, d = nearest
            if d <= R:
                roots.append(c)
                self.walk(self.root(c, cam))
        for i, p in enumerate(L.portals):
            if p.exterior or p.transform is not None or self.closed[i]:
                continue
            b = L.portals[p.partner] if p.partner is not None else p
            here = dist(p.plane, eye)
            depth = dist(b.plane, eye)
            doorway = abs(p.plane[1] + b.plane[1]) if p.partner is not None else 0.0
            if here >= -R and depth >= -R and max(here, depth) <= doorway + R and \
                    distance_to_polygon(sub(eye, mul(p.plane[0], here)), p.polygon,
                                        p.plane[0]) <= R:
                for c in (p.source, p.target):
                    if c not in roots:
                        roots.append(c)
                        self.walk(self.root(c, cam))

    def visit(self, fr):
        st = self.stats
        st["entered"] += 1
        if fr.depth > st["deepest"]:
            st["deepest"] = fr.depth
        rect = fr.view.rect
        e = None
        if fr.D is None:
            idx = self.direct.get(fr.region)
            if idx is not None:
                e = self.visible[idx]
        else:
            D = fr.D
            lim = 1e-9 * (1 + max(abs(D[12]), abs(D[13]), abs(D[14]), abs(D[15])))
            for cand in self.visible:
                if cand.D is not None and cand.cell == fr.cell and \
                        all(abs(cand.D[i] - D[i]) <= lim for i in range(16)):
                    e = cand
                    break
        if e is not None:
            r = e.rect
            e.rect = (min(r[0], rect[0]), min(r[1], rect[1]), max(r[2], rect[2]),
                      max(r[3], rect[3]))
            if fr.depth < e.depth:
                e.depth = fr.depth
                e.via = [s[0] for s in self.path]
            return
        e = Entry()
        e.cell = fr.cell
        e.rect = rect
        e.depth = fr.depth
        e.via = [s[0] for s in self.path]
        e.D = fr.D
        e.mirrored = fr.mirrored
        if fr.D is None:
            self.direct[fr.region] = len(self.visible)
        self.visible.append(e)

    def walk(self, fr):
        L = self.level
        self.visit(fr)
        marked = False
        if fr.D is None and fr.cell is not None:
            self.on_path_cells[fr.cell] = True
            marked = True
        eye = self.cam.eye
        eye_here = eye if fr.D is None else mat_point(fr.D_inv, eye)
        if fr.D is None and fr.region == L.N:
            ls = self.outside_links
        else:
            ls = L.links[fr.region]
        for link in ls:
            self.cross(fr, link, eye_here)
        if marked:
            self.on_path_cells[fr.cell] = False

    def on_path(self, portal):
        for step in reversed(self.path):
            if step[0] == portal:
                return True
            if step[1]:
                return False
        return False

    def cross(self, fr, link, eye_here):
        L = self.level
        st = self.stats
        cam = self.cam
        R = cam.R
        tol = L.tol
        pi, to, reversed_, plane = link
        p = L.portals[pi]
        st["portals_tested"] += 1
        if self.closed[pi]:
            st["closed_skipped"] += 1
            return
        s = -dist(plane, eye_here)
        if s < -R:
            st["portals_culled"] += 1
            return
        standing_in = s <= R and distance_to_polygon(eye_here, p.polygon, plane[0]) <= R
        if s < -tol and not standing_in:
            st["portals_culled"] += 1
            return
        T = p.transform if (p.transform is not None and not reversed_) else None
        if T is None:
            if (fr.D is None and to < L.N and self.on_path_cells[to]) or self.on_path(pi):
                st["on_path_skipped"] += 1
                return
        if self.pvs_row is not None and fr.D is None and T is None and to < L.N and \
                to not in L.pvs[self.pvs_row]:
            st["pvs_skipped"] += 1
            return
        if fr.depth >= self.max_depth:
            st["depth_limit_hits"] += 1
            return
        if T is not None and fr.transforms >= self.max_transform_depth:
            st["transform_limit_hits"] += 1
            return
        if standing_in:
            st["passed_through"] += 1
            view = fr.view
            if fr.D is None and T is None:
                rec = self.passed.get(to)
                if rec is not None and rec[0] is view and rec[1] <= fr.depth:
                    return
                self.passed[to] = (view, fr.depth)
        elif s <= tol:
            st["portals_culled"] += 1
            return
        else:
            view = self.narrow(fr, p.polygon, T is not None)
            if view is None:
                st["portals_culled"] += 1
                return
        self.descend(fr, pi, to, T, p, view)

    def narrow(self, fr, polygon, transformed):
        cam = self.cam
        eye = cam.eye
        tol = self.level.tol
        if fr.D is None:
            a = polygon
        else:
            a = [mat_point(fr.D, c) for c in polygon]
        surface = None
        if transformed:
            nw = newell(a)
            if nw != (0.0, 0.0, 0.0):
                n = normalize(nw)
                h = (n, dot(n, mean(a)))
                surface = flipped(h) if dist(h, eye) < 0 else h
        for h in fr.view.clips:
            if all(dist(h, c) <= tol for c in a):
                continue
            a = clip(a, h, tol)
            if len(a) < 3:
                break
        if len(a) < 3:
            return None
        f, r, u = cam.f, cam.r, cam.u
        tx, ty = cam.tan_x, cam.tan_y
        hn = cam.near / 2
        q = []
        for c in a:
            v = (c[0] - eye[0], c[1] - eye[1], c[2] - eye[2])
            z = max(dot(v, f), hn)
            q.append((dot(v, r) / (z * tx), dot(v, u) / (z * ty)))
        got = clip_screen(fr.view.polygon, fr.view.rect, q)
        if got is None:
            return None
        clips = fr.view.clips + [surface] if surface is not None else fr.view.clips
        return View(got[0], clips, got[1])

    def descend(self, fr, pi, to, T, p, view):
        L = self.level
        if T is None:
            D, D_inv, mirrored, n_t = fr.D, fr.D_inv, fr.mirrored, fr.transforms
        else:
            if fr.D is not None:
                Dp, Dp_inv = fr.D, fr.D_inv
            else:
                Dp, Dp_inv = IDENTITY, IDENTITY
            D = mat_mul(Dp, p.inverse)
            D_inv = mat_mul(T, Dp_inv)
            mirrored = fr.mirrored != (p.det < 0)
            n_t = fr.transforms + 1
        self.path.append((pi, T is not None))
        nf = Frame()
        nf.region = to
        nf.cell = to if to < L.N else None
        nf.view = view
        nf.depth = fr.depth + 1
        nf.transforms = n_t
        nf.D = D
        nf.D_inv = D_inv
        nf.mirrored = mirrored
        self.walk(nf)
        self.path.pop()


# ---------------------------------------------------------------- output

def r9(x):
    y = x * 1e9
    if y >= 0:
        y = math.floor(y + 0.5)
    else:
        y = -math.floor(-y + 0.5)
    v = y / 1e9
    if v == 0:
        v = 0.0
    return v


def draw_list(level, cells):
    nodes = set()
    per = {}
    for c in cells:
        cell = level.cells[c]
        for n in cell.nodes:
            if n not in level.split_nodes:
                nodes.add(n)
        for k, first, count in cell.draws:
            per.setdefault(k, []).append((first, count))
    ranges = []
    for k in sorted(per):
        rs = sorted(per[k])
        sp = level.split_prims[k]
        cur_first, cur_end = None, None
        for first, count in rs:
            end = first + count
            if cur_first is not None and first <= cur_end:
                if end > cur_end:
                    cur_end = end
                continue
            if cur_first is not None:
                ranges.append([sp["node"], sp["primitive"], cur_first, cur_end - cur_first])
            cur_first, cur_end = first, end
        if cur_first is not None:
            ranges.append([sp["node"], sp["primitive"], cur_first, cur_end - cur_first])
    return {"nodes": sorted(nodes), "ranges": ranges}


def answer(level, tracer, loc, draw):
    kind, val = loc
    out = {}
    if kind == "outside":
        out["cell"] = None
        out["location"] = "outside"
        out["nearest"] = val[0] if val is not None else None
    else:
        out["cell"] = val
        out["location"] = kind
    vis = []
    for e in tracer.visible:
        o = {"cell": e.cell, "rect": [r9(x) for x in e.rect], "depth": e.depth, "via": e.via}
        if e.D is not None:
            o["transform"] = [r9(x) for x in e.D]
        o["mirrored"] = e.mirrored
        if draw and e.D is not None:
            # not in the spec's text: found from the vectors (a transformed entry carries
            # its own cell's draw list)
            o["draw"] = draw_list(level, [e.cell] if e.cell is not None else [])
        vis.append(o)
    out["visible"] = vis
    if draw:
        cells = [e.cell for e in tracer.visible if e.D is None and e.cell is not None]
        out["draw"] = draw_list(level, cells)
    out["stats"] = dict(tracer.stats)
    return out


def main(argv):
    args = argv[1:]
    if not args or args[0] != "cull":
        sys.stderr.write(__doc__)
        return 2
    args = args[1:]
    level_path = None
    cameras = None
    closed_ids, open_ids = [], []
    use_pvs = True
    max_depth, tdepth = 32, 2
    draw = False
    fmt = "jsonl"
    i = 0
    while i < len(args):
        a = args[i]
        if a == "--cameras":
            cameras = args[i + 1]
            i += 2
        elif a == "--closed":
            closed_ids.append(int(args[i + 1]))
            i += 2
        elif a == "--open":
            open_ids.append(int(args[i + 1]))
            i += 2
        elif a == "--no-pvs":
            use_pvs = False
            i += 1
        elif a == "--max-depth":
            max_depth = int(args[i + 1])
            i += 2
        elif a == "--transform-depth":
            tdepth = int(args[i + 1])
            i += 2
        elif a == "--draw-lists":
            draw = True
            i += 1
        elif a == "--format":
            fmt = args[i + 1]
            i += 2
        elif a.startswith("-") and a != "-":
            sys.stderr.write(f"unknown option {a}\n")
            return 2
        else:
            level_path = a
            i += 1
    try:
        level = Level(level_path)
    except Refused as e:
        sys.stderr.write(f"refused: {e}\n")
        return 2
    closed = [p.closed for p in level.portals]
    given = {}
    for ids, state in ((closed_ids, True), (open_ids, False)):
        for pid in ids:
            if not (0 <= pid < len(level.portals)):
                sys.stderr.write(f"CULL_PORTAL_UNKNOWN: {pid}\n")
                return 2
            q = level.portals[pid].partner
            for x in {pid, q} - {None}:
                if x in given and (x == pid or given[x] != state):
                    sys.stderr.write(f"door options repeat or contradict portal {pid}\n")
                    return 2
            given[pid] = state
    for ids, state in ((closed_ids, True), (open_ids, False)):
        for pid in ids:
            if not (0 <= pid < len(level.portals)):
                sys.stderr.write(f"CULL_PORTAL_UNKNOWN: {pid}\n")
                return 2
            closed[pid] = state
            q = level.portals[pid].partner
            if q is not None:
                closed[q] = state
    tracer = Tracer(level, closed, use_pvs, max_depth, tdepth)
    src = sys.stdin if cameras == "-" else open(cameras)
    outs = []
    w = sys.stdout.write
    for line in iter(src.readline, ""):
        if not line.strip():
            continue
        try:
            cam = Camera(json.loads(line), level.tol)
        except (Refused, ValueError, TypeError, KeyError):
            sys.stderr.write("CULL_CAMERA_INVALID\n")
            return 2
        loc = tracer.trace(cam)
        o = answer(level, tracer, loc, draw)
        if fmt == "json":
            outs.append(o)
        else:
            w(json.dumps(o, separators=(",", ":")) + "\n")
            sys.stdout.flush()
    if fmt == "json":
        w(json.dumps(outs) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
