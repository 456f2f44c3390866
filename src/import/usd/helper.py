"""portcullis's USD reader, run inside the embedded interpreter (src/import/usd/python.rs).

Kept small on purpose: it walks the composed stage and hands every kept prim back as flat
values (strings, floats and buffer-protocol arrays: Vt arrays, Gf matrices, array.array), so
that all geometry decisions (axis and unit conversion, triangulation, holes, winding) are made
once, in Rust, with the project's exact predicates. No numpy: usd-core does not need it.
"""

import json
import re
from array import array

# Where `convert -o OUT.usda` writes cells and portals (src/export/usd_out.rs); not level
# geometry, and replaced when such a file is converted again.
ANNOTATION = "/PortcullisAnnotation"

# Prim types that are data for other prims, never scene nodes.
_SHADING = ("Material", "Shader", "NodeGraph", "GeomSubset")


class OpenError(Exception):
    """The stage could not be opened; the message is USD's own, cleaned of C++ noise."""


def _usd_message(exc):
    text = str(exc)
    parts = re.findall(r"Error in '[^']*' at line \d+ in file \S+ : '(.*?)'(?=\n\s*Error in|\s*$)",
                       text, re.S)
    parts = [p.strip() for p in parts if p.strip()] or [text.strip()]
    msg = "; ".join(parts)
    return re.sub(r"pxrInternal_v\w+?__pxrReserved__::", "", msg)


def _jsonable(v):
    if v is None or isinstance(v, (bool, int, str)):
        return v
    if isinstance(v, float):
        return v if v == v and v not in (float("inf"), float("-inf")) else None
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    path = getattr(v, "path", None)  # Sdf.AssetPath, Sdf.Path
    if isinstance(path, str):
        return path
    try:
        return [_jsonable(x) for x in v]
    except TypeError:
        return str(v)


def _merge(into, d):
    for k, v in d.items():
        if isinstance(v, dict) and isinstance(into.get(k), dict):
            _merge(into[k], v)
        else:
            into[k] = v


def _nested(name, value):
    """`a:b:c` = v  ->  {a: {b: {c: v}}}, as USD nests ':' keys in customData too."""
    out = value
    for part in reversed(name.split(":")):
        out = {part: out}
    return out


def _extras(prim, time):
    """Tags as JSON text: customData (only what the file authored: GetCustomData() would add
    schema documentation), a converter's `gltf:extras` lifted to the top, then custom
    attributes (`userProperties:` as Blender writes them is dropped), strongest last."""
    out = {}
    for spec in reversed(prim.GetPrimStack()):
        cd = _jsonable(dict(spec.customData))
        if cd:
            gltf = cd.get("gltf")
            if isinstance(gltf, dict) and isinstance(gltf.get("extras"), dict):
                _merge(out, gltf.pop("extras"))
                if not gltf:
                    cd.pop("gltf")
            _merge(out, cd)
    for attr in prim.GetAuthoredAttributes():
        if not attr.IsCustom():
            continue
        name = attr.GetName()
        for prefix in ("userProperties:", "primvars:"):
            if name.startswith(prefix):
                name = name[len(prefix):]
        _merge(out, _nested(name, _jsonable(attr.Get(time))))
    return json.dumps(out, allow_nan=False) if out else None


def load(path):
    """Returns (up_axis, meters_per_unit, prims, materials, notes).

    prims: one tuple per kept prim (a PointInstancer's prototypes once per instance, their
      paths suffixed `[k]`), parents before children:
      (path, name, parent index or -1, type name, world matrix (Gf.Matrix4d, row vectors),
       extras JSON or None, mesh key or None, mesh or None)
    mesh (sent once per key; instance proxies share their prototype's key):
      (points Vec3fArray, faceVertexCounts, faceVertexIndices, holeIndices, left_handed,
       per-face material index array or None)
    notes: (kind, prim path) pairs for things Rust reports: "portal_light", "hidden",
      "gprim:<type>", "units_default", and ("composition", USD's message).
    """
    try:
        from pxr import Usd, UsdGeom, UsdLux, UsdShade
    except ImportError as e:
        raise ImportError(str(e)) from None
    try:
        stage = Usd.Stage.Open(path)
    except Exception as e:  # Tf.ErrorException: parse errors, missing layers
        raise OpenError(_usd_message(e)) from None
    if stage is None:
        raise OpenError("USD could not open the file")

    time = Usd.TimeCode.EarliestTime()
    xforms = UsdGeom.XformCache(time)
    up = str(UsdGeom.GetStageUpAxis(stage))
    mpu = float(UsdGeom.GetStageMetersPerUnit(stage))

    notes = []
    # A reference, payload or sublayer that could not be opened: what it held is missing.
    for err in list(stage.GetCompositionErrors())[:20]:
        notes.append(("composition", str(err)))
    if not stage.HasAuthoredMetadata("metersPerUnit"):
        notes.append(("units_default", "/"))
    materials = []
    material_index = {}

    def material_of(prim):
        mat, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
        if not mat:
            return -1
        p = mat.GetPrim()
        key = str(p.GetPath())
        if key not in material_index:
            name = p.GetDisplayName() if p.HasAuthoredDisplayName() else p.GetName()
            material_index[key] = len(materials)
            materials.append((key, name))
        return material_index[key]

    prims = []
    sent = set()
    predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)

    def left_out(prim, it):
        """Whether `prim` is not a node; prunes what is below it where that goes too."""
        type_name = str(prim.GetTypeName())
        if type_name in _SHADING or str(prim.GetPath()) == ANNOTATION:
            it.PruneChildren()
            return True
        if prim.HasAPI(UsdLux.LightAPI):
            if prim.IsA(UsdLux.PortalLight):
                notes.append(("portal_light", str(prim.GetPath())))
            return True
        if prim.IsA(UsdGeom.Imageable):
            img = UsdGeom.Imageable(prim)
            if (img.ComputeVisibility(time) == UsdGeom.Tokens.invisible
                    or img.ComputePurpose() in (UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy)):
                notes.append(("hidden", str(prim.GetPath())))
                it.PruneChildren()
                return True
        return False

    def emit(prim, parent, world, path):
        type_name = str(prim.GetTypeName())
        key = None
        mesh = None
        if prim.IsA(UsdGeom.Mesh):
            key = str((prim.GetPrimInPrototype() if prim.IsInstanceProxy() else prim).GetPath())
            if key not in sent:
                sent.add(key)
                mesh = _mesh(UsdGeom.Mesh(prim), time, material_of, UsdGeom)
        elif prim.IsA(UsdGeom.Gprim):
            notes.append(("gprim:" + type_name, path))
        name = prim.GetDisplayName() if prim.HasAuthoredDisplayName() else prim.GetName()
        prims.append((path, name, parent, type_name, world, _extras(prim, time), key, mesh))
        return len(prims) - 1

    def walk(root, parent_index, world_of, path_of, include_root):
        """Emits `root`'s subtree; prims under a PointInstancer are emitted per instance."""
        index = {}
        it = iter(Usd.PrimRange(root, predicate))
        for prim in it:
            if prim == root and not include_root:
                continue
            if left_out(prim, it):
                continue
            parent = parent_index
            p = prim.GetParent() if prim != root else None
            while p and p != root.GetParent() and not p.IsPseudoRoot():
                k = str(p.GetPath())
                if k in index:
                    parent = index[k]
                    break
                p = p.GetParent()
            world = world_of(prim)
            i = emit(prim, parent, world, path_of(prim))
            index[str(prim.GetPath())] = i
            if prim.IsA(UsdGeom.PointInstancer):
                # Its prototypes are drawn only where the instancer places them.
                it.PruneChildren()
                instances(UsdGeom.PointInstancer(prim), i, world)

    def instances(pi, parent_index, inst_world):
        P = UsdGeom.PointInstancer
        mats = pi.ComputeInstanceTransformsAtTime(time, time, P.IncludeProtoXform, P.IgnoreMask)
        ids = pi.GetProtoIndicesAttr().Get(time) or []
        targets = pi.GetPrototypesRel().GetTargets()
        mask = pi.ComputeMaskAtTime(time) or []
        for k, m in enumerate(mats or []):
            if (k < len(mask) and not mask[k]) or k >= len(ids) or not 0 <= ids[k] < len(targets):
                continue
            proto = stage.GetPrimAtPath(targets[ids[k]])
            if not proto:
                continue
            base = m * inst_world  # row vectors: instance space, then the instancer's world

            def world_of(p, proto=proto, base=base):
                if p == proto:
                    return base
                rel, _ = xforms.ComputeRelativeTransform(p, proto)
                return rel * base

            walk(proto, parent_index, world_of, lambda p, k=k: f"{p.GetPath()}[{k}]", True)

    walk(stage.GetPseudoRoot(), -1, xforms.GetLocalToWorldTransform, lambda p: str(p.GetPath()),
         False)
    return up, mpu, prims, materials, notes


def _mesh(mesh, time, material_of, UsdGeom):
    def get(attr, empty):
        v = attr.Get(time)
        return empty if v is None else v

    points = get(mesh.GetPointsAttr(), array("f"))
    if memoryview(points).format != "f":  # points authored with the wrong type (point3d[])
        points = array("f", [c for p in points for c in p])
    counts = get(mesh.GetFaceVertexCountsAttr(), array("i"))
    indices = get(mesh.GetFaceVertexIndicesAttr(), array("i"))
    holes = get(mesh.GetHoleIndicesAttr(), array("i"))
    left = mesh.GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded
    prim = mesh.GetPrim()
    base = material_of(prim)
    face_mat = None
    subsets = UsdGeom.Subset.GetGeomSubsets(mesh, UsdGeom.Tokens.face, "materialBind")
    if subsets:
        face_mat = array("i", [base]) * len(counts)
        for s in subsets:
            m = material_of(s.GetPrim())
            for f in s.GetIndicesAttr().Get(time) or []:
                if 0 <= f < len(face_mat):
                    face_mat[f] = m
    elif base >= 0:
        face_mat = array("i", [base]) * len(counts)
    return (points, counts, indices, holes, left, face_mat)
