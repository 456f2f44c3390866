//! The annotated level as a USD text layer (`convert IN -o OUT.usda`).
//!
//! Written directly as `.usda` text, so it needs neither the `usd` feature nor Python: the
//! layer holds only plain prims (Xform, Mesh, Material, GeomSubset, Scope) whose syntax is
//! small and stable. The scene's node tree becomes the prim tree (each node's transform
//! relative to its parent as one `xformOp:transform`; names made valid USD identifiers, the
//! original kept as `displayName`, which the importer reads back); extras become customData.
//! Cells and portals live on `/PortcullisAnnotation` as custom attributes in the `portcullis:`
//! namespace (documented in docs/guide.md, "USD output"), with the PVS when one was computed; the
//! importer ignores that prim, so converting an annotated file again replaces the annotation
//! instead of reading it as level.

use crate::level::Level;
use std::collections::HashSet;
use std::fmt::Write;

use glam::{DMat4, DVec3};
use serde_json::Value;

use crate::cells::CellSet;
use crate::portals::PortalSet;
use crate::scene::{NodeId, Scene};
use crate::tags::rules::PortalKind;
use crate::tags::Tagging;
use crate::vis::{Method, Pvs};

/// The root prim holding the annotation; skipped by the USD importer.
pub(crate) const ANNOTATION_PRIM: &str = "PortcullisAnnotation";
/// The root scope holding the materials.
const LOOKS_PRIM: &str = "PortcullisLooks";

/// A valid USD identifier for `name` (letters, digits, `_`; not starting with a digit).
fn identifier(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.starts_with(|c: char| c.is_ascii_digit()) {
        s.insert(0, '_');
    }
    s
}

/// A name unique among `taken`, which it is added to.
fn unique(base: String, taken: &mut HashSet<String>) -> String {
    let mut name = base.clone();
    let mut k = 1;
    while !taken.insert(name.clone()) {
        name = format!("{base}_{k}");
        k += 1;
    }
    name
}

fn quote(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 => {}
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

fn v3(p: DVec3) -> String {
    format!("({}, {}, {})", p.x, p.y, p.z)
}

/// USD matrices are row-major with row vectors: the rows are glam's columns.
fn matrix(m: &DMat4) -> String {
    let c = m.to_cols_array_2d();
    let rows: Vec<String> = c
        .iter()
        .map(|r| format!("({}, {}, {}, {})", r[0], r[1], r[2], r[3]))
        .collect();
    format!("( {} )", rows.join(", "))
}

struct Writer<'a> {
    scene: &'a Scene,
    out: String,
    /// The written prim path of every node.
    paths: Vec<String>,
    /// Cells rendering each node.
    node_cells: Vec<Vec<usize>>,
    material_paths: Vec<String>,
}

impl Writer<'_> {
    fn line(&mut self, depth: usize, text: &str) {
        for _ in 0..depth {
            self.out.push_str("    ");
        }
        self.out.push_str(text);
        self.out.push('\n');
    }

    /// Prim paths for every node and material, fixed before writing so relationships can
    /// point forward.
    fn assign_paths(&mut self, roots_taken: &mut HashSet<String>) {
        let scene = self.scene;
        let mut stack: Vec<(NodeId, String)> = Vec::new();
        let names = |parent: &str, ids: &[NodeId], taken: &mut HashSet<String>| {
            ids.iter()
                .map(|&id| {
                    let n = unique(identifier(&scene.node_label(id)), taken);
                    (id, format!("{parent}/{n}"))
                })
                .collect::<Vec<_>>()
        };
        stack.extend(names("", &scene.roots, roots_taken).into_iter().rev());
        while let Some((id, path)) = stack.pop() {
            let mut taken = HashSet::new();
            let kids = names(&path, &scene.nodes[id].children, &mut taken);
            self.paths[id] = path;
            stack.extend(kids.into_iter().rev());
        }
        let mut taken = HashSet::new();
        for (i, m) in scene.materials.iter().enumerate() {
            let label = m.name.clone().unwrap_or_else(|| format!("material_{i}"));
            let n = unique(identifier(&label), &mut taken);
            self.material_paths.push(format!("/{LOOKS_PRIM}/{n}"));
        }
    }

    fn node(&mut self, id: NodeId, depth: usize) {
        let scene = self.scene;
        let node = &scene.nodes[id];
        let path = self.paths[id].clone();
        let prim_name = path.rsplit('/').next().unwrap_or_default().to_string();
        let ty = if node.mesh.is_some() { "Mesh" } else { "Xform" };
        let mut meta: Vec<String> = Vec::new();
        if let Some(name) = node.name.as_deref() {
            if name != prim_name {
                meta.push(format!("displayName = {}", quote(name)));
            }
        }
        let material = node.mesh.and_then(|m| {
            let mats: HashSet<_> = scene.meshes[m]
                .primitives
                .iter()
                .map(|p| p.material)
                .collect();
            (mats.len() == 1)
                .then(|| mats.into_iter().next().flatten())
                .flatten()
        });
        if material.is_some() {
            meta.push("prepend apiSchemas = [\"MaterialBindingAPI\"]".into());
        }
        if let Some(Value::Object(o)) = &node.extras {
            if !o.is_empty() {
                let mut cd = String::from("customData = {\n");
                dictionary(&mut cd, o, depth + 2);
                for _ in 0..=depth {
                    cd.push_str("    ");
                }
                cd.push('}');
                meta.push(cd);
            }
        }
        if meta.is_empty() {
            self.line(depth, &format!("def {ty} \"{prim_name}\""));
        } else {
            self.line(depth, &format!("def {ty} \"{prim_name}\" ("));
            for m in &meta {
                self.line(depth + 1, m);
            }
            self.line(depth, ")");
        }
        self.line(depth, "{");
        let local = match node.parent {
            Some(p) => {
                let pw = scene.nodes[p].world;
                if pw.determinant().abs() > 1e-300 {
                    (pw.inverse() * node.world, false)
                } else {
                    (node.world, true)
                }
            }
            None => (node.world, false),
        };
        if local.0 != DMat4::IDENTITY || local.1 {
            self.line(
                depth + 1,
                &format!("matrix4d xformOp:transform = {}", matrix(&local.0)),
            );
            let order = if local.1 {
                "[\"!resetXformStack!\", \"xformOp:transform\"]"
            } else {
                "[\"xformOp:transform\"]"
            };
            self.line(
                depth + 1,
                &format!("uniform token[] xformOpOrder = {order}"),
            );
        }
        if let Some(m) = node.mesh {
            self.mesh(m, material, depth + 1);
        }
        if !self.node_cells[id].is_empty() {
            let cells: Vec<String> = self.node_cells[id].iter().map(|c| c.to_string()).collect();
            self.line(
                depth + 1,
                &format!("custom int[] portcullis:cells = [{}]", cells.join(", ")),
            );
        }
        for (k, &c) in node.children.iter().enumerate() {
            if k > 0 {
                self.out.push('\n');
            }
            self.node(c, depth + 1);
        }
        self.line(depth, "}");
    }

    fn mesh(&mut self, m: usize, material: Option<usize>, depth: usize) {
        let mesh = &self.scene.meshes[m];
        let pts: Vec<String> = mesh
            .positions
            .iter()
            .map(|p| format!("({}, {}, {})", p.x as f32, p.y as f32, p.z as f32))
            .collect();
        let idx: Vec<String> = mesh
            .triangles
            .iter()
            .flat_map(|t| t.iter().map(|i| i.to_string()))
            .collect();
        let counts = vec!["3"; mesh.triangles.len()].join(", ");
        self.line(depth, &format!("int[] faceVertexCounts = [{counts}]"));
        self.line(
            depth,
            &format!("int[] faceVertexIndices = [{}]", idx.join(", ")),
        );
        self.line(depth, &format!("point3f[] points = [{}]", pts.join(", ")));
        self.line(depth, "uniform token subdivisionScheme = \"none\"");
        if let Some(mat) = material {
            let target = self.material_paths[mat].clone();
            self.line(depth, &format!("rel material:binding = <{target}>"));
            return;
        }
        // Several materials: one GeomSubset per primitive that has one.
        for (k, p) in mesh.primitives.iter().enumerate() {
            let Some(mat) = p.material else { continue };
            let target = self.material_paths[mat].clone();
            let faces: Vec<String> = (p.first_triangle..p.first_triangle + p.triangle_count)
                .map(|f| f.to_string())
                .collect();
            self.line(
                depth,
                &format!(
                    "def GeomSubset \"portcullis_subset_{k}\" (\n{}    prepend apiSchemas = [\"MaterialBindingAPI\"]\n{})",
                    "    ".repeat(depth),
                    "    ".repeat(depth)
                ),
            );
            self.line(depth, "{");
            self.line(depth + 1, "uniform token elementType = \"face\"");
            self.line(depth + 1, "uniform token familyName = \"materialBind\"");
            self.line(
                depth + 1,
                &format!("int[] indices = [{}]", faces.join(", ")),
            );
            self.line(depth + 1, &format!("rel material:binding = <{target}>"));
            self.line(depth, "}");
        }
    }
}

/// customData entries for a JSON object (strings, numbers, booleans, nested objects; arrays
/// of one scalar type; anything else as its JSON text).
fn dictionary(out: &mut String, o: &serde_json::Map<String, Value>, depth: usize) {
    let pad = "    ".repeat(depth);
    for (k, v) in o {
        let key = if identifier(k) == *k {
            k.clone()
        } else {
            quote(k)
        };
        let entry = match v {
            Value::Null => continue,
            Value::Bool(b) => format!("bool {key} = {}", u8::from(*b)),
            Value::Number(n) => format!("double {key} = {}", n.as_f64().unwrap_or(0.0)),
            Value::String(s) => format!("string {key} = {}", quote(s)),
            Value::Object(inner) => {
                let mut s = format!("dictionary {key} = {{\n");
                dictionary(&mut s, inner, depth + 1);
                s.push_str(&pad);
                s.push('}');
                s
            }
            Value::Array(a) if !a.is_empty() && a.iter().all(Value::is_string) => {
                let items: Vec<String> = a.iter().filter_map(Value::as_str).map(quote).collect();
                format!("string[] {key} = [{}]", items.join(", "))
            }
            Value::Array(a) if !a.is_empty() && a.iter().all(Value::is_number) => {
                let items: Vec<String> = a
                    .iter()
                    .filter_map(Value::as_f64)
                    .map(|x| x.to_string())
                    .collect();
                format!("double[] {key} = [{}]", items.join(", "))
            }
            Value::Array(_) => format!("string {key} = {}", quote(&v.to_string())),
        };
        let _ = writeln!(out, "{pad}{entry}");
    }
}

/// The level, its cells and portals as one `.usda` layer (Y-up, metres).
pub(crate) fn write_usda(level: &Level, pvs: Option<(&Pvs, Method)>) -> String {
    let (scene, tagging, cells, portals) =
        (level.scene(), level.tagging(), &level.cells, &level.portals);
    let mut w = Writer {
        scene,
        out: String::new(),
        paths: vec![String::new(); scene.nodes.len()],
        node_cells: vec![Vec::new(); scene.nodes.len()],
        material_paths: Vec::new(),
    };
    for (ci, c) in cells.cells.iter().enumerate() {
        for &n in &c.nodes {
            if let Some(v) = w.node_cells.get_mut(n) {
                v.push(ci);
            }
        }
    }
    let mut roots_taken: HashSet<String> =
        [ANNOTATION_PRIM.to_string(), LOOKS_PRIM.to_string()].into();
    w.assign_paths(&mut roots_taken);
    let default_prim = scene
        .roots
        .first()
        .map(|&r| w.paths[r].trim_start_matches('/').to_string())
        .unwrap_or_else(|| ANNOTATION_PRIM.to_string());
    w.out.push_str("#usda 1.0\n(\n");
    let _ = writeln!(w.out, "    defaultPrim = {}", quote(&default_prim));
    let _ = writeln!(
        w.out,
        "    doc = {}",
        quote(&format!(
            "Written by portcullis {} from {}: the level with its cells and portals (custom attributes in the portcullis: namespace on /{ANNOTATION_PRIM})",
            env!("CARGO_PKG_VERSION"),
            scene.path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
        ))
    );
    w.out
        .push_str("    metersPerUnit = 1\n    upAxis = \"Y\"\n)\n");
    for &r in &scene.roots {
        w.out.push('\n');
        w.node(r, 0);
    }
    if !scene.materials.is_empty() {
        w.out.push('\n');
        w.line(0, &format!("def Scope \"{LOOKS_PRIM}\""));
        w.line(0, "{");
        for (i, m) in scene.materials.iter().enumerate() {
            let path = w.material_paths[i].clone();
            let name = path.rsplit('/').next().unwrap_or_default().to_string();
            match m.name.as_deref() {
                Some(orig) if orig != name => {
                    w.line(1, &format!("def Material \"{name}\" ("));
                    w.line(2, &format!("displayName = {}", quote(orig)));
                    w.line(1, ")");
                }
                _ => w.line(1, &format!("def Material \"{name}\"")),
            }
            w.line(1, "{");
            w.line(1, "}");
        }
        w.line(0, "}");
    }
    annotation(&mut w, tagging, cells, portals, pvs);
    w.out
}

fn annotation(
    w: &mut Writer<'_>,
    tagging: &Tagging,
    cells: &CellSet,
    portals: &PortalSet,
    pvs: Option<(&Pvs, Method)>,
) {
    let hash = super::input_hash(w.scene, tagging);
    w.out.push('\n');
    w.line(0, &format!("def Scope \"{ANNOTATION_PRIM}\""));
    w.line(0, "{");
    w.line(1, "custom int portcullis:version = 1");
    w.line(
        1,
        &format!("custom string portcullis:inputHash = {}", quote(&hash)),
    );
    w.line(1, "def Scope \"Cells\"");
    w.line(1, "{");
    for (i, c) in cells.cells.iter().enumerate() {
        w.line(2, &format!("def Scope \"cell{i}\""));
        w.line(2, "{");
        let room = &tagging.rooms[c.room].name;
        w.line(
            3,
            &format!("custom string portcullis:room = {}", quote(room)),
        );
        let planes: Vec<String> = c
            .poly
            .faces
            .iter()
            .map(|f| {
                let n = f.plane.normal;
                format!("({}, {}, {}, {})", n.x, n.y, n.z, f.plane.d)
            })
            .collect();
        w.line(
            3,
            &format!(
                "custom double4[] portcullis:planes = [{}]",
                planes.join(", ")
            ),
        );
        w.line(
            3,
            &format!("custom double3 portcullis:boundsMin = {}", v3(c.bounds.min)),
        );
        w.line(
            3,
            &format!("custom double3 portcullis:boundsMax = {}", v3(c.bounds.max)),
        );
        let nodes: Vec<String> = c
            .nodes
            .iter()
            .filter_map(|&n| w.paths.get(n))
            .map(|p| format!("<{p}>"))
            .collect();
        w.line(
            3,
            &format!("custom rel portcullis:nodes = [{}]", nodes.join(", ")),
        );
        w.line(2, "}");
    }
    w.line(1, "}");
    w.line(1, "def Scope \"Portals\"");
    w.line(1, "{");
    for (i, p) in portals.portals.iter().enumerate() {
        w.line(2, &format!("def Scope \"portal{i}\""));
        w.line(2, "{");
        w.line(3, &format!("custom int portcullis:from = {}", p.from));
        let to = p.to.map_or(-1, |t| t as i64);
        w.line(3, &format!("custom int portcullis:to = {to}"));
        let poly: Vec<String> = p.polygon.iter().map(|q| v3(*q)).collect();
        w.line(
            3,
            &format!(
                "custom double3[] portcullis:polygon = [{}]",
                poly.join(", ")
            ),
        );
        let kind = match p.kind {
            PortalKind::Plain => "plain",
            PortalKind::Mirror => "mirror",
            PortalKind::Teleporter => "teleporter",
        };
        w.line(3, &format!("custom token portcullis:kind = \"{kind}\""));
        if p.one_way {
            w.line(3, "custom bool portcullis:oneWay = 1");
        }
        if p.closed {
            w.line(3, "custom bool portcullis:closed = 1");
        }
        if let Some(partner) = p.partner {
            w.line(3, &format!("custom int portcullis:partner = {partner}"));
        }
        if let Some(t) = &p.transform {
            w.line(
                3,
                &format!("custom matrix4d portcullis:transform = {}", matrix(t)),
            );
        }
        if let Some(n) = p.authored.and_then(|n| w.paths.get(n)).cloned() {
            w.line(3, &format!("custom rel portcullis:authored = <{n}>"));
        }
        w.line(2, "}");
    }
    w.line(1, "}");
    if let Some((pvs, method)) = pvs {
        visibility(w, pvs, method);
    }
    w.line(0, "}");
}

/// The PVS as the glTF extension's `lists` encoding says it, in two flat arrays USD holds
/// natively: the cells visible from cell `c` (ascending, `c` included) are
/// `visible[offsets[c] .. offsets[c + 1]]`.
fn visibility(w: &mut Writer<'_>, pvs: &Pvs, method: Method) {
    let mut offsets = vec![0usize];
    let mut visible = Vec::new();
    for c in 0..pvs.cells() {
        visible.extend(pvs.visible(c));
        offsets.push(visible.len());
    }
    let list = |v: &[usize]| {
        v.iter()
            .map(|i| i.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    w.line(1, "def Scope \"Visibility\"");
    w.line(1, "{");
    w.line(
        2,
        &format!("custom token portcullis:method = \"{}\"", method.name()),
    );
    w.line(
        2,
        &format!("custom int[] portcullis:offsets = [{}]", list(&offsets)),
    );
    w.line(
        2,
        &format!("custom int[] portcullis:visible = [{}]", list(&visible)),
    );
    w.line(1, "}");
}
