//! Scenarios for the engine-side runtime (`portcullis::runtime`): levels built in code as the
//! `PORTCULLIS_portals` extension's root object, then located in and traced from cameras. Every
//! expectation is worked out independently of the runtime (by hand, or by projecting sample
//! points with a camera model written here), so each test can fail.

use glam::{DMat4, DVec3};
use portcullis::format::Annotated;
use portcullis::runtime::{Doors, Level, Location, Trace, TraceOptions, View, Visible};
use serde_json::{json, Value};

const NEAR: f64 = 0.05;
const FOV: f64 = 60.0;
const ASPECT: f64 = 16.0 / 9.0;
const TOL: f64 = 1e-5;

// ---------------------------------------------------------------------------------------------
// Building levels

/// The extension's root object, built up one cell and portal at a time.
#[derive(Default)]
struct Builder {
    cells: Vec<Value>,
    portals: Vec<Value>,
    visibility: Option<Value>,
}

impl Builder {
    /// An axis-aligned box cell: six planes with outward unit normals, and its bounds.
    fn room(&mut self, name: &str, min: [f64; 3], max: [f64; 3]) -> usize {
        self.cells.push(json!({
            "room": name,
            "planes": [
                [-1.0, 0.0, 0.0, -min[0]], [1.0, 0.0, 0.0, max[0]],
                [0.0, -1.0, 0.0, -min[1]], [0.0, 1.0, 0.0, max[1]],
                [0.0, 0.0, -1.0, -min[2]], [0.0, 0.0, 1.0, max[2]],
            ],
            "bounds": {"min": min, "max": max},
        }));
        self.cells.len() - 1
    }

    /// A portal record as given (`polygon`, `cells` and any flags); returns its index.
    fn portal(&mut self, record: Value) -> usize {
        self.portals.push(record);
        self.portals.len() - 1
    }

    /// A two-way opening between `a` and `b`: the portal from `a` with `poly` wound
    /// counter-clockwise seen from `a` (as `convert` writes it: its Newell normal towards
    /// `a`'s middle), and its partner from `b` with the polygon reversed. Returns
    /// `(a -> b, b -> a)`.
    fn door(&mut self, a: usize, b: usize, poly: &[[f64; 3]]) -> (usize, usize) {
        let poly = facing(poly, self.centre(a));
        let i = self.portals.len();
        self.portals
            .push(json!({"polygon": poly, "cells": [a, b], "partner": i + 1}));
        self.portals
            .push(json!({"polygon": reversed(&poly), "cells": [b, a], "partner": i}));
        (i, i + 1)
    }

    /// The middle of cell `c`'s bounds.
    fn centre(&self, c: usize) -> DVec3 {
        let corner = |k: &str| -> DVec3 {
            DVec3::from(
                serde_json::from_value::<[f64; 3]>(self.cells[c]["bounds"][k].clone()).unwrap(),
            )
        };
        (corner("min") + corner("max")) / 2.0
    }

    /// Checks the test data keeps `convert`'s convention: a portal lying on a face of its
    /// source cell's box is wound counter-clockwise seen from the cell (its Newell normal
    /// points into it).
    fn check_winding(&self) {
        for (i, p) in self.portals.iter().enumerate() {
            let poly: Vec<[f64; 3]> = serde_json::from_value(p["polygon"].clone()).unwrap();
            let from = p["cells"][0].as_u64().unwrap() as usize;
            let bounds = |k: &str| -> [f64; 3] {
                serde_json::from_value(self.cells[from]["bounds"][k].clone()).unwrap()
            };
            let (min, max) = (bounds("min"), bounds("max"));
            let on_face = (0..3).any(|k| {
                poly.iter().all(|v| v[k] == min[k]) || poly.iter().all(|v| v[k] == max[k])
            });
            if on_face {
                let c = poly.iter().map(|v| DVec3::from(*v)).sum::<DVec3>() / poly.len() as f64;
                assert!(
                    newell(&poly).dot(self.centre(from) - c) > 0.0,
                    "test data: portal {i} is not wound counter-clockwise from its source"
                );
            }
        }
    }

    /// Stores a PVS as `lists` (per cell, the cells it sees).
    fn pvs(&mut self, lists: Value) {
        self.visibility = Some(json!({"method": "full", "encoding": "lists", "lists": lists}));
    }

    fn json(&self) -> Value {
        let mut v = json!({
            "version": 1,
            "generator": "portcullis runtime_scenarios",
            "inputHash": "xxh3:0000000000000000",
            "tolerance": TOL,
            "cells": self.cells,
            "portals": self.portals,
        });
        if let Some(vis) = &self.visibility {
            v["visibility"] = vis.clone();
        }
        v
    }

    fn level(&self) -> Level {
        self.check_winding();
        let a: Annotated = serde_json::from_value(self.json()).expect("the annotation parses");
        let pvs = a.visibility.as_ref().map(|vis| {
            portcullis::format::visibility::decode(vis, a.cells.len(), None).expect("PVS decodes")
        });
        Level::from_annotation(&a, pvs).expect("the level loads")
    }
}

/// `b`'s level moved by `o`: planes, bounds, polygons, and transforms conjugated.
fn shifted(b: &Builder, o: [f64; 3]) -> Builder {
    let ov = DVec3::from(o);
    let move_point = |p: &Value| {
        let v: [f64; 3] = serde_json::from_value(p.clone()).unwrap();
        json!((DVec3::from(v) + ov).to_array())
    };
    let mut out = Builder {
        cells: b.cells.clone(),
        portals: b.portals.clone(),
        visibility: b.visibility.clone(),
    };
    for c in &mut out.cells {
        for plane in c["planes"].as_array_mut().unwrap() {
            let h: [f64; 4] = serde_json::from_value(plane.clone()).unwrap();
            let d = h[3] + DVec3::new(h[0], h[1], h[2]).dot(ov);
            *plane = json!([h[0], h[1], h[2], d]);
        }
        for k in ["min", "max"] {
            c["bounds"][k] = move_point(&c["bounds"][k]);
        }
    }
    for p in &mut out.portals {
        let moved: Vec<Value> = p["polygon"]
            .as_array()
            .unwrap()
            .iter()
            .map(move_point)
            .collect();
        p["polygon"] = json!(moved);
        if let Some(t) = p.get("transform").cloned() {
            let m: [f64; 16] = serde_json::from_value(t).unwrap();
            let m = DMat4::from_translation(ov)
                * DMat4::from_cols_array(&m)
                * DMat4::from_translation(-ov);
            p["transform"] = json!(cols(m));
        }
    }
    out
}

/// A rectangle on the plane `axis = at`, spanning `lo..hi` along the two other axes (in the
/// order `axis+1`, `axis+2`), wound counter-clockwise about `+axis`.
fn rect(axis: usize, at: f64, lo: [f64; 2], hi: [f64; 2]) -> Vec<[f64; 3]> {
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    [
        (lo[0], lo[1]),
        (hi[0], lo[1]),
        (hi[0], hi[1]),
        (lo[0], hi[1]),
    ]
    .iter()
    .map(|&(a, b)| {
        let mut p = [0.0; 3];
        p[axis] = at;
        p[u] = a;
        p[v] = b;
        p
    })
    .collect()
}

fn reversed(poly: &[[f64; 3]]) -> Vec<[f64; 3]> {
    poly.iter().rev().copied().collect()
}

/// The Newell normal of a polygon (not normalised).
fn newell(poly: &[[f64; 3]]) -> DVec3 {
    let v: Vec<DVec3> = poly.iter().map(|p| DVec3::from(*p)).collect();
    (0..v.len())
        .map(|i| (v[i] - v[0]).cross(v[(i + 1) % v.len()] - v[0]))
        .sum()
}

/// `poly` wound counter-clockwise seen from `p` (its Newell normal towards `p`).
fn facing(poly: &[[f64; 3]], p: DVec3) -> Vec<[f64; 3]> {
    let c = poly.iter().map(|v| DVec3::from(*v)).sum::<DVec3>() / poly.len() as f64;
    if newell(poly).dot(p - c) >= 0.0 {
        poly.to_vec()
    } else {
        reversed(poly)
    }
}

fn cols(m: DMat4) -> Vec<f64> {
    m.to_cols_array().to_vec()
}

/// Rooms A = [0,4]x[0,3]x[0,4] (cell 0) and B = [4,8]x[0,3]x[0,4] (cell 1) joined by a doorway
/// 1 m wide (z 1.5..2.5) and 2.2 m tall in the wall x = 4: portal 0 from A, portal 1 from B.
fn two_rooms() -> Builder {
    let mut b = Builder::default();
    let a = b.room("a", [0.0, 0.0, 0.0], [4.0, 3.0, 4.0]);
    let c = b.room("b", [4.0, 0.0, 0.0], [8.0, 3.0, 4.0]);
    b.door(a, c, &door_at(4.0));
    b
}

/// The doorway of [`two_rooms`] on the plane x = `x`.
fn door_at(x: f64) -> Vec<[f64; 3]> {
    Opening { x, ..DOOR }.polygon()
}

/// Three rooms in a row along x (A, B, C: cells 0, 1, 2), each 4 m, with doorways on the
/// same axis (z 1.5..2.5): portals 0/1 between A and B, 2/3 between B and C.
fn three_rooms() -> Builder {
    let mut b = Builder::default();
    for (i, name) in ["a", "b", "c"].iter().enumerate() {
        let x = 4.0 * i as f64;
        b.room(name, [x, 0.0, 0.0], [x + 4.0, 3.0, 4.0]);
    }
    b.door(0, 1, &door_at(4.0));
    b.door(1, 2, &door_at(8.0));
    b
}

// ---------------------------------------------------------------------------------------------
// Cameras and traces

fn up_for(look: [f64; 3]) -> [f64; 3] {
    let l = DVec3::from(look).normalize();
    if l.y.abs() > 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    }
}

fn view(eye: [f64; 3], look: [f64; 3]) -> View {
    View::new(eye, look, up_for(look), FOV, ASPECT, NEAR).expect("a valid camera")
}

fn trace_with(level: &Level, doors: &Doors, opts: &TraceOptions, v: &View) -> Trace {
    let mut t = Trace::default();
    level.trace(v, doors, opts, &mut t);
    check_trace(level, &t);
    t
}

fn trace(level: &Level, eye: [f64; 3], look: [f64; 3]) -> Trace {
    trace_with(
        level,
        &Doors::new(level),
        &TraceOptions::default(),
        &view(eye, look),
    )
}

/// What every trace must satisfy: the camera's region first at depth 0, rectangles ordered
/// and within NDC, `via` as long as `depth`, mirrored entries with a reflecting transform.
fn check_trace(level: &Level, t: &Trace) {
    let vis = t.visible();
    assert!(!vis.is_empty(), "the camera's own region is always visible");
    assert_eq!(
        vis[0].cell,
        t.location.cell(),
        "first entry: the camera's region"
    );
    assert_eq!(vis[0].depth, 0);
    assert!(vis[0].transform.is_none());
    for v in vis {
        let r = v.rect;
        assert!(
            r.iter().all(|x| x.is_finite() && (-1.0..=1.0).contains(x)),
            "rect {r:?} outside NDC"
        );
        assert!(r[0] <= r[2] && r[1] <= r[3], "rect {r:?} is not ordered");
        assert_eq!(t.via(v).len(), v.depth, "via of {v:?}");
        assert!(t.via(v).iter().all(|&p| (p as usize) < level.portals()));
        if let Some(c) = v.cell {
            assert!(c < level.cells());
        }
        match v.transform {
            None => assert!(!v.mirrored),
            Some(m) => assert_eq!(v.mirrored, m.determinant() < 0.0, "{v:?}"),
        }
    }
}

/// The regions of the untransformed entries, sorted (`None`, the outside, first).
fn seen(t: &Trace) -> Vec<Option<usize>> {
    let mut out: Vec<_> = t
        .visible()
        .iter()
        .filter(|v| v.transform.is_none())
        .map(|v| v.cell)
        .collect();
    out.sort();
    out
}

fn entry(t: &Trace, cell: Option<usize>) -> Option<(usize, &Visible)> {
    t.visible()
        .iter()
        .enumerate()
        .find(|(_, v)| v.cell == cell && v.transform.is_none())
}

/// A pinhole camera written independently of `runtime::View`: what lies in its frustum.
struct Cam {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    tan_x: f64,
    tan_y: f64,
}

impl Cam {
    fn new(eye: [f64; 3], look: [f64; 3]) -> Cam {
        Cam::with(eye, look, FOV, ASPECT)
    }

    fn with(eye: [f64; 3], look: [f64; 3], fov_y: f64, aspect: f64) -> Cam {
        let forward = DVec3::from(look).normalize();
        let right = forward.cross(DVec3::from(up_for(look))).normalize();
        let tan_y = (fov_y.to_radians() / 2.0).tan();
        Cam {
            eye: DVec3::from(eye),
            forward,
            right,
            up: right.cross(forward),
            tan_x: tan_y * aspect,
            tan_y,
        }
    }

    /// Whether any point of the convex polygon `poly` (sampled) lies in the frustum.
    fn sees_any(&self, poly: &[[f64; 3]]) -> bool {
        let v: Vec<DVec3> = poly.iter().map(|p| DVec3::from(*p)).collect();
        (0..=20).any(|i| {
            (0..=20).any(|j| {
                let (a, b) = (i as f64 / 20.0, j as f64 / 20.0);
                // A quad: bilinear between its corners.
                let p = v[0].lerp(v[1], a).lerp(v[3].lerp(v[2], a), b);
                self.ndc(p, 0.0).is_some()
            })
        })
    }

    /// NDC of `p` when it lies beyond the near plane and inside the frustum by `margin`.
    fn ndc(&self, p: DVec3, margin: f64) -> Option<[f64; 2]> {
        let v = p - self.eye;
        let z = v.dot(self.forward);
        if z < NEAR + margin {
            return None;
        }
        let x = v.dot(self.right) / (z * self.tan_x);
        let y = v.dot(self.up) / (z * self.tan_y);
        (x.abs() <= 1.0 - margin && y.abs() <= 1.0 - margin).then_some([x, y])
    }

    /// Distance from the eye to the near plane's corners.
    fn near_radius(&self) -> f64 {
        NEAR * (1.0 + self.tan_x * self.tan_x + self.tan_y * self.tan_y).sqrt()
    }
}

/// Points strictly inside the box `min..max`, on a grid of `n` per axis.
fn grid(min: [f64; 3], max: [f64; 3], n: usize) -> Vec<DVec3> {
    let (min, max) = (DVec3::from(min), DVec3::from(max));
    let inset = 0.02;
    let mut out = Vec::new();
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let t = DVec3::new(i as f64, j as f64, k as f64) / (n - 1) as f64;
                out.push(min + inset + (max - min - 2.0 * inset) * t);
            }
        }
    }
    out
}

/// A rectangular opening in the plane x = `x`, spanning `y` and `z`.
#[derive(Clone, Copy, Debug)]
struct Opening {
    x: f64,
    y: [f64; 2],
    z: [f64; 2],
}

impl Opening {
    fn polygon(&self) -> Vec<[f64; 3]> {
        rect(0, self.x, [self.y[0], self.z[0]], [self.y[1], self.z[1]])
    }

    /// Whether the segment from `e` to `p` crosses the opening's plane within it, shrunk by
    /// `margin`.
    fn crossed(&self, e: DVec3, p: DVec3, margin: f64) -> bool {
        let (de, dp) = (e.x - self.x, p.x - self.x);
        if de * dp > 0.0 {
            return false;
        }
        let c = if de == dp {
            e
        } else {
            e + (p - e) * (de / (de - dp))
        };
        c.y >= self.y[0] + margin
            && c.y <= self.y[1] - margin
            && c.z >= self.z[0] + margin
            && c.z <= self.z[1] - margin
    }
}

/// The doorway of [`two_rooms`].
const DOOR: Opening = Opening {
    x: 4.0,
    y: [0.0, 2.2],
    z: [1.5, 2.5],
};

/// Whether the segment from `e` to `p` crosses the plane x = `x` within the doorway of
/// [`door_at`] (shrunk by `margin`).
fn crosses_door(e: DVec3, p: DVec3, x: f64, margin: f64) -> bool {
    Opening { x, ..DOOR }.crossed(e, p, margin)
}

/// A small deterministic generator (64-bit LCG), for sweeps that do not change between runs.
struct Lcg(u64);

impl Lcg {
    /// Uniform in `lo..hi`.
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }
}

fn translation(x: f64, y: f64, z: f64) -> DMat4 {
    DMat4::from_translation(DVec3::new(x, y, z))
}

/// The reflection in the plane x = `x0`: x -> 2 x0 - x.
fn reflection_x(x0: f64) -> DMat4 {
    translation(2.0 * x0, 0.0, 0.0) * DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0))
}

// ---------------------------------------------------------------------------------------------
// 1. The eye relative to a portal's plane

const LOOKS: [[f64; 3]; 10] = [
    [1.0, 0.0, 0.0],   // through the door into B
    [-1.0, 0.0, 0.0],  // through the door into A
    [0.0, 0.0, 1.0],   // along the wall
    [0.0, 0.0, -1.0],  // along the wall
    [0.0, 1.0, 0.0],   // up, along the wall
    [0.0, -1.0, 0.0],  // down, along the wall
    [1.0, 0.0, 1.0],   // diagonal into B
    [-1.0, 0.0, 1.0],  // diagonal into A
    [1.0, 0.3, -0.6],  // askew into B
    [-0.2, 0.1, -1.0], // mostly along the wall
];

/// A visible point `p` (at NDC `xy`) of entry `i`: inside its scissor rectangle, and a tiny
/// box at it passes `box_visible`.
fn check_point_drawn(label: &str, t: &Trace, i: usize, v: &Visible, p: DVec3, xy: [f64; 2]) {
    let eps = 1e-9;
    let [x, y] = xy;
    assert!(
        x >= v.rect[0] - eps
            && x <= v.rect[2] + eps
            && y >= v.rect[1] - eps
            && y <= v.rect[3] + eps,
        "{label}: point {p} at NDC {xy:?} outside the rect {:?} of entry {i}",
        v.rect
    );
    let h = DVec3::splat(1e-6);
    assert!(
        t.box_visible(i, p - h, p + h),
        "{label}: a tiny box at visible point {p} is culled in entry {i}"
    );
}

/// Checks one camera of the two-room level against sample points of the other room: when a
/// point of it lies in the frustum and the segment from the eye reaches it through the
/// doorway, the other room is traced, its rectangle holds the point's NDC, and a tiny box at
/// the point is visible through it. When no point of the doorway is in view and the camera
/// does not stand in it, the other room is not traced.
fn check_other_room(level: &Level, eye: [f64; 3], look: [f64; 3], own_expected: Option<usize>) {
    let t = trace(level, eye, look);
    let label = format!("eye {eye:?} look {look:?}");
    let own = t
        .location
        .cell()
        .unwrap_or_else(|| panic!("{label}: the eye is in a room"));
    if let Some(c) = own_expected {
        assert_eq!(own, c, "{label}: camera cell");
    }
    let other = 1 - own;
    let (omin, omax) = level.bounds(other);
    let cam = Cam::new(eye, look);
    let e = DVec3::from(eye);
    let visible_points: Vec<(DVec3, [f64; 2])> = grid(omin, omax, 11)
        .into_iter()
        .filter_map(|p| {
            let ndc = cam.ndc(p, 1e-6)?;
            crosses_door(e, p, 4.0, 1e-6).then_some((p, ndc))
        })
        .collect();
    let got = entry(&t, Some(other));
    if visible_points.is_empty() {
        // The doorway wholly out of a slightly widened frustum, and the camera farther from
        // it than the near plane's corners: nothing of the other room can be drawn.
        let door_in_view = (0..=40).any(|i| {
            (0..=40).any(|j| {
                let p = DVec3::new(4.0, 2.2 * i as f64 / 40.0, 1.5 + j as f64 / 40.0);
                cam.ndc(p, -1e-3).is_some()
            })
        });
        let door_distance = {
            let q = DVec3::new(4.0, e.y.clamp(0.0, 2.2), e.z.clamp(1.5, 2.5));
            e.distance(q)
        };
        if !door_in_view && door_distance > cam.near_radius() + 1e-3 {
            assert!(
                got.is_none(),
                "{label}: room {other} traced but not visible"
            );
        }
        return;
    }
    let Some((i, v)) = got else {
        panic!(
            "{label}: room {other} not traced though {} sample points of it are visible, \
             e.g. {:?}; trace: {:?}",
            visible_points.len(),
            visible_points[0],
            t.visible()
        );
    };
    for &(p, [x, y]) in &visible_points {
        check_point_drawn(&label, &t, i, v, p, [x, y]);
    }
}

#[test]
fn eye_on_the_door_axis_at_every_distance_from_the_portal_plane() {
    let level = two_rooms().level();
    let offsets = [
        -2.0 * NEAR,
        -NEAR / 2.0,
        -1e-3,
        0.0,
        1e-3,
        NEAR / 2.0,
        2.0 * NEAR,
    ];
    for s in offsets {
        let own = if s < 0.0 {
            Some(0)
        } else if s > 0.0 {
            Some(1)
        } else {
            None
        };
        for look in LOOKS {
            check_other_room(&level, [4.0 + s, 1.1, 2.0], look, own);
        }
    }
    // Looking straight through the doorway into the other room, it is always there; within
    // the near radius (standing in the doorway) even looking back.
    for s in offsets {
        for look in [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]] {
            let t = trace(&level, [4.0 + s, 1.1, 2.0], look);
            if s * look[0] <= 0.0 || s.abs() < NEAR {
                assert_eq!(seen(&t), [Some(0), Some(1)], "s = {s}, look {look:?}");
            }
        }
    }
    // Two near radii away and looking away from the door, the other room is not traced.
    let t = trace(&level, [4.0 - 2.0 * NEAR, 1.1, 2.0], [-1.0, 0.0, 0.0]);
    assert_eq!(seen(&t), [Some(0)]);
    assert_eq!(t.location, Location::Inside(0));
    let t = trace(&level, [4.0 + 2.0 * NEAR, 1.1, 2.0], [1.0, 0.0, 0.0]);
    assert_eq!(seen(&t), [Some(1)]);
    assert_eq!(t.location, Location::Inside(1));
}

#[test]
fn eye_near_the_door_edges_never_loses_the_other_room() {
    // Off the axis: near the jambs and the lintel, close to the plane, in many directions.
    let level = two_rooms().level();
    for s in [-0.2, -0.06, -0.03, -1e-3, 1e-3, 0.03, 0.06, 0.2] {
        for z in [1.2, 1.4, 1.47, 1.55, 2.0, 2.45, 2.53, 2.6, 2.8] {
            for y in [0.3, 1.1, 2.1, 2.25, 2.4] {
                for look in LOOKS {
                    check_other_room(&level, [4.0 + s, y, z], look, Some(usize::from(s > 0.0)));
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 2. A room seen only through a corridor's second portal

/// A = [0,4]x[0,3]x[0,4] (0), corridor B = [4,8]x[0,3]x[0,2] (1), C = [4,8]x[0,3]x[2,6] (2)
/// beside A: doorway A-B in x = 4 (z 0.5..1.5; portals 0, 1), doorway B-C in z = 2
/// (x 6.5..7.5; portals 2, 3). C shares the wall x = 4 with A but has no opening in it.
fn l_shape() -> Level {
    let mut b = Builder::default();
    let a = b.room("a", [0.0, 0.0, 0.0], [4.0, 3.0, 4.0]);
    let corridor = b.room("b", [4.0, 0.0, 0.0], [8.0, 3.0, 2.0]);
    let c = b.room("c", [4.0, 0.0, 2.0], [8.0, 3.0, 6.0]);
    b.door(a, corridor, &L_FIRST);
    b.door(corridor, c, &L_SECOND);
    b.level()
}

/// The doorways of [`l_shape`]: A-B in x = 4, B-C in z = 2.
const L_FIRST: [[f64; 3]; 4] = [
    [4.0, 0.0, 0.5],
    [4.0, 2.2, 0.5],
    [4.0, 2.2, 1.5],
    [4.0, 0.0, 1.5],
];
const L_SECOND: [[f64; 3]; 4] = [
    [6.5, 0.0, 2.0],
    [7.5, 0.0, 2.0],
    [7.5, 2.2, 2.0],
    [6.5, 2.2, 2.0],
];

#[test]
fn room_seen_only_through_the_corridors_second_portal() {
    let level = l_shape();
    let eye = [1.0, 1.5, 0.3];
    // Aimed at the middle of the second doorway, through the first.
    let look = [6.0, -0.4, 1.7];
    let cam = Cam::new(eye, look);
    let target = DVec3::new(7.0, 1.1, 2.0);
    assert!(cam.ndc(target, 0.0).is_some());
    let t = trace(&level, eye, look);
    assert_eq!(t.location, Location::Inside(0));
    assert_eq!(seen(&t), [Some(0), Some(1), Some(2)]);
    let (_, b) = entry(&t, Some(1)).unwrap();
    assert_eq!((b.depth, t.via(b)), (1, &[0u32][..]));
    let (ci, c) = entry(&t, Some(2)).unwrap();
    assert_eq!((c.depth, t.via(c)), (2, &[0u32, 2][..]));
    assert_eq!(t.stats.deepest, 2);
    // A box in C just past the second doorway is visible; one in C behind the wall it
    // shares with A is not.
    // (Through both doorways, C shows only a sliver by its wall x = 8, z 2..2.5.)
    assert!(t.box_visible(ci, DVec3::new(7.5, 1.0, 2.05), DVec3::new(7.9, 1.2, 2.15)));
    assert!(!t.box_visible(ci, DVec3::new(4.2, 1.0, 3.0), DVec3::new(4.6, 1.4, 3.5)));

    // Turned 15 degrees away (to -z) with a 40-degree square view: the frustum spans -35..+5
    // degrees, the first doorway (3.8..21.8 degrees from the eye) is at its edge and the
    // second (14.7..17.2 degrees) outside it.
    let a = (-15f64).to_radians();
    let look = [a.cos(), 0.0, a.sin()];
    let turned = Cam::with(eye, look, 40.0, 1.0);
    assert!(turned.sees_any(&L_FIRST) && !turned.sees_any(&L_SECOND));
    let v = View::new(eye, look, [0.0, 1.0, 0.0], 40.0, 1.0, NEAR).unwrap();
    let t = trace_with(&level, &Doors::new(&level), &TraceOptions::default(), &v);
    assert_eq!(seen(&t), [Some(0), Some(1)], "{:?}", t.visible());
    // Turned so neither doorway is in view: A alone.
    let away = Cam::new(eye, [-1.0, 0.0, -0.2]);
    assert!(!away.sees_any(&L_FIRST) && !away.sees_any(&L_SECOND));
    let t = trace(&level, eye, [-1.0, 0.0, -0.2]);
    assert_eq!(seen(&t), [Some(0)]);
}

/// Checks that every sample point of `cell` seen from the camera through `openings` (in order)
/// is in the trace: its cell traced, its NDC within the scissor rect, a tiny box at it visible.
/// Returns how many sample points were seen.
fn check_seen_through(
    level: &Level,
    t: &Trace,
    cam: &Cam,
    cell: usize,
    openings: &[Opening],
    label: &str,
) -> usize {
    check_seen(level, t, cam, cell, None, openings, label)
}

/// As [`check_seen_through`], for the copy of `cell` drawn with `draw` (cell space to camera
/// space; `None`: the identity) seen through `openings` given in camera space: the entry for
/// that cell and transform must hold every such point.
fn check_seen(
    level: &Level,
    t: &Trace,
    cam: &Cam,
    cell: usize,
    draw: Option<DMat4>,
    openings: &[Opening],
    label: &str,
) -> usize {
    let (min, max) = level.bounds(cell);
    let found = t.visible().iter().enumerate().find(|(_, v)| {
        v.cell == Some(cell)
            && match (v.transform, draw) {
                (None, None) => true,
                (Some(a), Some(b)) => a.abs_diff_eq(b, 1e-9),
                _ => false,
            }
    });
    let mut count = 0;
    for p in grid(min, max, 9) {
        let q = draw.map_or(p, |m| m.transform_point3(p));
        let Some([x, y]) = cam.ndc(q, 1e-6) else {
            continue;
        };
        if !openings.iter().all(|o| o.crossed(cam.eye, q, 1e-6)) {
            continue;
        }
        count += 1;
        let Some((i, v)) = found else {
            panic!(
                "{label}: cell {cell} (drawn with {draw:?}) not traced though {p} is seen; {:?}",
                t.visible()
            );
        };
        check_point_drawn(label, t, i, v, p, [x, y]);
    }
    count
}

#[test]
fn random_cameras_in_a_row_of_offset_rooms_miss_nothing() {
    // A, B, C along x; doorway A-B at x = 4 (z 0.5..1.5), B-C at x = 8 (z 2.5..3.5, raised).
    let ab = Opening {
        x: 4.0,
        y: [0.0, 2.2],
        z: [0.5, 1.5],
    };
    let bc = Opening {
        x: 8.0,
        y: [0.4, 2.8],
        z: [2.5, 3.5],
    };
    let mut b = Builder::default();
    for (i, name) in ["a", "b", "c"].iter().enumerate() {
        let x = 4.0 * i as f64;
        b.room(name, [x, 0.0, 0.0], [x + 4.0, 3.0, 4.0]);
    }
    b.door(0, 1, &ab.polygon());
    b.door(1, 2, &bc.polygon());
    let level = b.level();
    let mut rng = Lcg(7);
    let (mut seen_b, mut seen_c) = (0, 0);
    for n in 0..1500 {
        let eye = [
            rng.range(0.05, 3.95),
            rng.range(0.2, 2.8),
            rng.range(0.05, 3.95),
        ];
        // Mostly towards +x, any tilt.
        let look = [
            rng.range(0.1, 1.0),
            rng.range(-0.5, 0.5),
            rng.range(-1.0, 1.0),
        ];
        let t = trace(&level, eye, look);
        assert_eq!(t.location, Location::Inside(0));
        let cam = Cam::new(eye, look);
        let label = format!("camera {n}: eye {eye:?} look {look:?}");
        seen_b += check_seen_through(&level, &t, &cam, 1, &[ab], &label);
        seen_c += check_seen_through(&level, &t, &cam, 2, &[ab, bc], &label);
        // C's entry, when there is one, came through both doorways.
        if let Some((_, c)) = entry(&t, Some(2)) {
            assert_eq!(t.via(c), [0, 2], "{label}");
        }
    }
    // The sweep did look through the doorways.
    assert!(seen_b > 1000 && seen_c > 20, "{seen_b} {seen_c}");
}

// ---------------------------------------------------------------------------------------------
// 3. A portal slightly off its cell's wall

#[test]
fn portal_slightly_off_the_wall_still_shows_the_neighbour() {
    for offset in [1e-4, -1e-4, 1e-2, -1e-2] {
        // Positive: outside A (into B); negative: inside A (outside B).
        let mut b = Builder::default();
        b.room("a", [0.0, 0.0, 0.0], [4.0, 3.0, 4.0]);
        b.room("b", [4.0, 0.0, 0.0], [8.0, 3.0, 4.0]);
        b.door(0, 1, &door_at(4.0 + offset));
        let level = b.level();
        let cameras: [([f64; 3], [f64; 3], usize); 6] = [
            ([1.0, 1.5, 2.0], [1.0, 0.0, 0.0], 0),
            ([3.0, 1.2, 0.5], [1.0, 0.0, 1.0], 0),
            ([3.7, 1.1, 2.2], [1.0, -0.1, 0.0], 0),
            ([7.0, 1.5, 2.0], [-1.0, 0.0, 0.0], 1),
            ([5.0, 1.2, 3.5], [-1.0, 0.0, -1.0], 1),
            ([4.3, 1.1, 1.8], [-1.0, 0.1, 0.0], 1),
        ];
        for (eye, look, own) in cameras {
            let t = trace(&level, eye, look);
            assert_eq!(t.location, Location::Inside(own));
            assert_eq!(
                seen(&t),
                [Some(0), Some(1)],
                "offset {offset}, eye {eye:?} look {look:?}"
            );
        }
    }
}

#[test]
fn camera_between_an_off_wall_portal_and_the_wall_still_sees_the_neighbour() {
    // The polygon of A -> B lies 1e-4 m inside A (x = 3.9999); the camera stands in A's
    // doorway at x = 3.99995 (5e-5 inside A, more than the tolerance: Inside(A)), looking
    // into B through the opening. The portal's polygon is 5e-5 m behind the eye, well within
    // the near radius, so the camera stands in the portal: it must pass through though the eye
    // is 5e-5 beyond the portal's plane (once culled on that distance alone, losing B though
    // every pixel of the view shows it).
    for (offset, x) in [(-1e-4, 3.99995), (-1e-2, 3.995)] {
        let mut b = Builder::default();
        b.room("a", [0.0, 0.0, 0.0], [4.0, 3.0, 4.0]);
        b.room("b", [4.0, 0.0, 0.0], [8.0, 3.0, 4.0]);
        b.door(0, 1, &door_at(4.0 + offset));
        let level = b.level();
        let t = trace(&level, [x, 1.1, 2.0], [1.0, 0.0, 0.0]);
        assert_eq!(t.location, Location::Inside(0));
        assert_eq!(
            seen(&t),
            [Some(0), Some(1)],
            "offset {offset}: {:?}",
            t.stats
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 4. Two facing mirrors

/// One cell [0,w]x[0,3]x[0,d] named `room` with a mirror on each of its x walls (portal 0 at
/// x = 0, portal 1 at x = w), each its own partner.
fn mirrored_box(room: &str, w: f64, d: f64) -> Level {
    let mut b = Builder::default();
    b.room(room, [0.0, 0.0, 0.0], [w, 3.0, d]);
    b.portal(json!({
        "polygon": rect(0, 0.0, [0.0, 0.0], [3.0, d]), "cells": [0, 0], "kind": "mirror",
        "transform": cols(reflection_x(0.0)), "partner": 0,
    }));
    b.portal(json!({
        "polygon": reversed(&rect(0, w, [0.0, 0.0], [3.0, d])), "cells": [0, 0],
        "kind": "mirror", "transform": cols(reflection_x(w)), "partner": 1,
    }));
    b.level()
}

/// One cell [0,4]x[0,3]x[0,4] with facing mirrors on its x walls.
fn mirror_room() -> Level {
    mirrored_box("hall", 4.0, 4.0)
}

/// Where the hall is drawn after `i` mirrors, starting with the one at x = 4 and alternating:
/// x -> 8 ceil(i/2) + (-1)^i x.
fn image(i: usize) -> DMat4 {
    let shift = 8.0 * i.div_ceil(2) as f64;
    if i % 2 == 1 {
        reflection_x(shift / 2.0)
    } else {
        translation(shift, 0.0, 0.0)
    }
}

#[test]
fn facing_mirrors_stop_at_the_transform_depth() {
    let level = mirror_room();
    assert_eq!(level.portal_kind(0), portcullis::runtime::Kind::Mirror);
    let v = view([1.0, 1.5, 2.0], [1.0, 0.0, 0.0]);
    for k in 1..=3 {
        let opts = TraceOptions {
            max_transform_depth: k,
            ..TraceOptions::default()
        };
        let t = trace_with(&level, &Doors::new(&level), &opts, &v);
        let vis = t.visible();
        // The hall itself, then one image per mirror crossed: 4, 0, 4, ... alternating.
        assert_eq!(vis.len(), k + 1, "k = {k}: {vis:?}");
        assert_eq!(t.stats.transform_limit_hits, 1, "k = {k}: {:?}", t.stats);
        assert_eq!(t.stats.depth_limit_hits, 0);
        assert_eq!(t.stats.deepest as usize, k);
        for (i, e) in vis.iter().enumerate() {
            assert_eq!(e.cell, Some(0));
            assert_eq!(e.depth, i);
            let via: Vec<u32> = (0..i).map(|j| if j % 2 == 0 { 1 } else { 0 }).collect();
            assert_eq!(t.via(e), via.as_slice());
            let odd = i % 2 == 1;
            assert_eq!(e.mirrored, odd, "entry {i}");
            if i == 0 {
                assert!(e.transform.is_none());
                continue;
            }
            let m = e.transform.expect("an image has a transform");
            assert_eq!(m.determinant() < 0.0, odd, "entry {i}: {m}");
            assert!(
                m.abs_diff_eq(image(i), 1e-9),
                "entry {i}: {m} instead of {}",
                image(i)
            );
            // Each image lies farther away, so its rectangle lies within the previous one.
            let p = vis[i - 1].rect;
            let r = e.rect;
            assert!(r[0] >= p[0] - 1e-9 && r[1] >= p[1] - 1e-9);
            assert!(r[2] <= p[2] + 1e-9 && r[3] <= p[3] + 1e-9);
        }
        // Every sample point of the hall seen in a reflection (through the mirror at x = 4,
        // then its images at x = 8, 12, ...) lies in that image's rect and views.
        let cam = Cam::new([1.0, 1.5, 2.0], [1.0, 0.0, 0.0]);
        for i in 0..=k {
            let walls: Vec<Opening> = (1..=i)
                .map(|j| Opening {
                    x: 4.0 * j as f64,
                    y: [0.0, 3.0],
                    z: [0.0, 4.0],
                })
                .collect();
            let draw = (i > 0).then(|| image(i));
            let n = check_seen(
                &level,
                &t,
                &cam,
                0,
                draw,
                &walls,
                &format!("k {k} image {i}"),
            );
            assert!(n > 100, "image {i}: {n} points seen");
        }
        // A box behind the camera is culled in the hall but seen in the first reflection.
        let (lo, hi) = (DVec3::new(0.3, 1.0, 1.8), DVec3::new(0.6, 1.3, 2.2));
        assert!(!t.box_visible(0, lo, hi));
        assert!(t.box_visible(1, lo, hi));
    }
}

/// A corridor [0,2]x[0,3]x[0,20] lined with mirrors along its length: portal 0 on x = 0,
/// portal 1 on x = 2, each its own partner.
fn mirror_corridor() -> Level {
    mirrored_box("gallery", 2.0, 20.0)
}

#[test]
fn facing_mirrors_seen_side_on_are_bounded_and_parity_holds() {
    let level = mirror_corridor();
    // Looking down the gallery: both mirrors are in view, and each image shows the other
    // mirror (the n-th image of a wall lies 2n - 1 m aside, in view within z = 20 up to n = 10).
    let v = view([1.0, 1.5, 0.3], [0.0, 0.0, 1.0]);
    let reflections = [reflection_x(0.0), reflection_x(2.0)];
    for k in 1..=3 {
        let opts = TraceOptions {
            max_transform_depth: k,
            ..TraceOptions::default()
        };
        let t = trace_with(&level, &Doors::new(&level), &opts, &v);
        let transformed: Vec<&Visible> = t
            .visible()
            .iter()
            .filter(|e| e.transform.is_some())
            .collect();
        assert_eq!(transformed.len(), 2 * k, "k = {k}: {transformed:?}");
        // Each chain stops at the mirror it would cross next.
        assert_eq!(t.stats.transform_limit_hits, 2, "k = {k}: {:?}", t.stats);
        assert_eq!(t.stats.deepest as usize, k);
        // Two chains of images, starting with either mirror and alternating: image i is the
        // product of the reflections crossed.
        for first in [0usize, 1] {
            let mut m = DMat4::IDENTITY;
            for i in 1..=k {
                let portal = (first + i - 1) % 2;
                m *= reflections[portal];
                let found: Vec<&&Visible> = transformed
                    .iter()
                    .filter(|e| e.transform.unwrap().abs_diff_eq(m, 1e-9))
                    .collect();
                assert_eq!(found.len(), 1, "k = {k}, first {first}, image {i}: {m}");
                let e = found[0];
                assert_eq!(e.depth, i);
                let via: Vec<u32> = (0..i).map(|j| ((first + j) % 2) as u32).collect();
                assert_eq!(t.via(e), via.as_slice());
            }
        }
        // Sample points of every image, seen through the chain of mirror images.
        let cam = Cam::new([1.0, 1.5, 0.3], [0.0, 0.0, 1.0]);
        for first in [0usize, 1] {
            let mut m = DMat4::IDENTITY;
            let mut walls = Vec::new();
            for i in 1..=k {
                let portal = (first + i - 1) % 2;
                m *= reflections[portal];
                // The mirror crossed, where this chain sees it: image i - 1 of its wall.
                let wall = if first == 1 {
                    2.0 * i as f64
                } else {
                    -2.0 * (i - 1) as f64
                };
                walls.push(Opening {
                    x: wall,
                    y: [0.0, 3.0],
                    z: [0.0, 20.0],
                });
                let label = format!("k {k} first {first} image {i}");
                let n = check_seen(&level, &t, &cam, 0, Some(m), &walls, &label);
                assert!(n > 0, "{label}: nothing seen");
            }
        }
        for e in t.visible() {
            let odd = e.depth % 2 == 1;
            assert_eq!(e.mirrored, odd, "{e:?}");
            match e.transform {
                None => assert_eq!(e.depth, 0),
                Some(m) => assert_eq!(m.determinant() < 0.0, odd, "{e:?}"),
            }
        }
    }
}

#[test]
fn facing_mirrors_without_a_transform_limit_stop_at_the_portal_depth() {
    let level = mirror_room();
    // Unbounded mirror depth: the portal depth bounds the walk.
    let opts = TraceOptions {
        max_depth: 6,
        max_transform_depth: usize::MAX,
        use_pvs: true,
    };
    let t = trace_with(
        &level,
        &Doors::new(&level),
        &opts,
        &view([1.0, 1.5, 2.0], [1.0, 0.0, 0.0]),
    );
    assert_eq!(t.visible().len(), 7);
    assert_eq!(t.stats.depth_limit_hits, 1);
    assert_eq!(t.stats.transform_limit_hits, 0);
    assert_eq!(t.stats.deepest, 6);
}

/// The hall [0,4]x[0,3]x[0,4] with a free-standing mirror (portal 0) in the plane x = 1
/// (y 0.5..2.5, z 1..3), reflecting in x = 1. `facing_centre`: its front faces +x (towards
/// the hall's middle); else -x (towards the strip x < 1 by the wall). The polygon is wound
/// counter-clockwise seen from its front, as `convert` writes it (src/portals/authored.rs).
fn free_standing_mirror(facing_centre: bool) -> Level {
    let front_plus_x = rect(0, 1.0, [0.5, 1.0], [2.5, 3.0]);
    let polygon = if facing_centre {
        front_plus_x
    } else {
        reversed(&front_plus_x)
    };
    let mut b = Builder::default();
    b.room("hall", [0.0, 0.0, 0.0], [4.0, 3.0, 4.0]);
    b.portal(json!({
        "polygon": polygon, "cells": [0, 0], "kind": "mirror",
        "transform": cols(reflection_x(1.0)), "partner": 0,
    }));
    b.level()
}

/// Whether the camera sees a reflection (an entry with a transform) and of what.
fn reflections(t: &Trace) -> Vec<(Option<usize>, usize, bool)> {
    t.visible()
        .iter()
        .filter(|v| v.transform.is_some())
        .map(|v| (v.cell, v.depth, v.mirrored))
        .collect()
}

#[test]
fn free_standing_mirror_facing_the_rooms_middle_reflects_only_in_front() {
    let level = free_standing_mirror(true);
    // In front (x > 1), looking at it: the hall reflected in x = 1.
    let t = trace(&level, [3.0, 1.5, 2.0], [-1.0, 0.0, 0.0]);
    assert_eq!(reflections(&t), [(Some(0), 1, true)]);
    let m = t.visible()[1].transform.unwrap();
    assert!(m.abs_diff_eq(reflection_x(1.0), 1e-9), "{m}");
    // Behind it (x < 1), looking at its back: no reflection.
    let t = trace(&level, [0.3, 1.5, 2.0], [1.0, 0.0, 0.0]);
    assert_eq!(reflections(&t), []);
}

#[test]
fn free_standing_mirror_facing_the_wall_reflects_only_in_front() {
    // The same mirror turned round: its front faces the 1 m strip by the wall x = 0, away from
    // the cell's middle (x = 2). Only the winding says which side is the front.
    let level = free_standing_mirror(false);
    let t = trace(&level, [0.3, 1.5, 2.0], [1.0, 0.0, 0.0]);
    assert_eq!(
        reflections(&t),
        [(Some(0), 1, true)],
        "in front: {:?}",
        t.stats
    );
    let t = trace(&level, [3.0, 1.5, 2.0], [-1.0, 0.0, 0.0]);
    assert_eq!(reflections(&t), [], "behind: no reflection");
}

#[test]
fn converted_free_standing_mirror_facing_the_wall_reflects_only_in_front() {
    // samples/mirror.gltf with its mirror quad (front -x) moved from the wall x = 4 to x = 1:
    // convert accepts it (the hall is in front of it) and writes the reflection in x = 1.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("samples/mirror.gltf")).unwrap();
    let mut doc: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(doc["nodes"][5]["name"], "Mirror");
    doc["nodes"][5]["translation"] = json!([-3.0, 0.0, 0.0]);
    let dir = tempfile::tempdir().unwrap();
    let (src, out) = (dir.path().join("m.gltf"), dir.path().join("m_out.gltf"));
    std::fs::write(&src, serde_json::to_string(&doc).unwrap()).unwrap();
    portcullis::pipeline::convert_file(&src, &out).unwrap();
    let level = Level::load(&out).unwrap();
    assert_eq!(level.portals(), 1);
    assert_eq!(level.portal_kind(0), portcullis::runtime::Kind::Mirror);
    let t = trace(&level, [0.3, 1.5, 2.0], [1.0, 0.0, 0.0]);
    assert_eq!(reflections(&t), [(Some(0), 1, true)], "in front");
    let t = trace(&level, [3.0, 1.5, 2.0], [-1.0, 0.0, 0.0]);
    assert_eq!(reflections(&t), [], "behind");
}

// ---------------------------------------------------------------------------------------------
// 5. A teleporter loop

/// A corridor [0,10]x[0,3]x[0,2] whose far end (x = 10, portal 0) teleports back to its start
/// (x = 0, portal 1): walking through x = 10 arrives at x = 0.
fn teleporter_loop() -> Level {
    let mut b = Builder::default();
    b.room("corridor", [0.0, 0.0, 0.0], [10.0, 3.0, 2.0]);
    b.portal(json!({
        "polygon": reversed(&rect(0, 10.0, [0.0, 0.0], [3.0, 2.0])), "cells": [0, 0],
        "kind": "teleporter",
        "transform": cols(translation(-10.0, 0.0, 0.0)), "partner": 1,
    }));
    b.portal(json!({
        "polygon": rect(0, 0.0, [0.0, 0.0], [3.0, 2.0]), "cells": [0, 0],
        "kind": "teleporter", "transform": cols(translation(10.0, 0.0, 0.0)), "partner": 0,
    }));
    b.level()
}

#[test]
fn teleporter_loop_terminates_with_composed_translations() {
    let level = teleporter_loop();
    let v = view([2.0, 1.5, 1.0], [1.0, 0.0, 0.0]);
    let doors = Doors::new(&level);
    for k in [1, 2, 5] {
        let opts = TraceOptions {
            max_transform_depth: k,
            ..TraceOptions::default()
        };
        let t = trace_with(&level, &doors, &opts, &v);
        let vis = t.visible();
        assert_eq!(vis.len(), k + 1, "k = {k}: {vis:?}");
        assert_eq!(t.stats.transform_limit_hits, 1, "k = {k}");
        assert_eq!(t.stats.depth_limit_hits, 0);
        for (i, e) in vis.iter().enumerate().skip(1) {
            assert_eq!((e.cell, e.depth, e.mirrored), (Some(0), i, false));
            assert!(t.via(e).iter().all(|&p| p == 0), "{:?}", t.via(e));
            let m = e.transform.unwrap();
            let expect = translation(10.0 * i as f64, 0.0, 0.0);
            assert!(m.abs_diff_eq(expect, 1e-9), "copy {i}: {m}");
        }
        // Sample points of each copy, seen through the teleporter and its copies.
        let cam = Cam::new([2.0, 1.5, 1.0], [1.0, 0.0, 0.0]);
        for i in 1..=k {
            let ends: Vec<Opening> = (1..=i)
                .map(|j| Opening {
                    x: 10.0 * j as f64,
                    y: [0.0, 3.0],
                    z: [0.0, 2.0],
                })
                .collect();
            let draw = translation(10.0 * i as f64, 0.0, 0.0);
            let n = check_seen(&level, &t, &cam, 0, Some(draw), &ends, &format!("copy {i}"));
            assert!(n > 0, "copy {i}: nothing seen");
        }
        // The start of the corridor, behind the camera, is seen in the first copy ahead.
        let (lo, hi) = (DVec3::new(0.5, 1.0, 0.5), DVec3::new(1.0, 1.5, 1.0));
        assert!(!t.box_visible(0, lo, hi));
        assert!(t.box_visible(1, lo, hi));
    }
    // With the portal depth lower than the transform depth, the portal depth stops it.
    let opts = TraceOptions {
        max_depth: 3,
        max_transform_depth: 10,
        use_pvs: true,
    };
    let t = trace_with(&level, &doors, &opts, &v);
    assert_eq!(t.visible().len(), 4);
    assert_eq!(t.stats.depth_limit_hits, 1);
    assert_eq!(t.stats.transform_limit_hits, 0);
    assert_eq!(t.stats.deepest, 3);
    let last = t.visible()[3].transform.unwrap();
    assert!(last.abs_diff_eq(translation(30.0, 0.0, 0.0), 1e-9));
    // Looking back at the start, the copies lie behind x = 0.
    let t = trace(&level, [8.0, 1.5, 1.0], [-1.0, 0.0, 0.0]);
    let shifts: Vec<f64> = t
        .visible()
        .iter()
        .map(|e| e.transform.map_or(0.0, |m| m.w_axis.x))
        .collect();
    assert_eq!(shifts, [0.0, -10.0, -20.0]);
    assert!(t.visible()[1..].iter().all(|e| t.via(e)[0] == 1));
}

#[test]
fn teleporter_with_a_turn_places_the_far_room_by_its_transform() {
    // A = [0,4]x[0,3]x[0,4] (0); B = [10,14]x[0,3]x[10,14] (1), apart. Walking into A's wall
    // x = 4 (y 0..2, z 1..3; portal 0) comes out of B's wall z = 10 (x 11..13; portal 1)
    // heading +z: a quarter turn about y, centre (4, 1, 2) to centre (12, 1, 10).
    let turn = DMat4::from_rotation_y(-std::f64::consts::FRAC_PI_2);
    let m = translation(12.0, 1.0, 10.0) * turn * translation(-4.0, -1.0, -2.0);
    assert!(m.transform_vector3(DVec3::X).abs_diff_eq(DVec3::Z, 1e-12));
    let mut b = Builder::default();
    b.room("a", [0.0, 0.0, 0.0], [4.0, 3.0, 4.0]);
    b.room("b", [10.0, 0.0, 10.0], [14.0, 3.0, 14.0]);
    let entry_poly = reversed(&rect(0, 4.0, [0.0, 1.0], [2.0, 3.0]));
    let exit_poly: Vec<[f64; 3]> = entry_poly
        .iter()
        .map(|p| m.transform_point3(DVec3::from(*p)).to_array())
        .collect();
    b.portal(json!({
        "polygon": entry_poly, "cells": [0, 1], "kind": "teleporter",
        "transform": cols(m), "partner": 1,
    }));
    b.portal(json!({
        "polygon": reversed(&exit_poly), "cells": [1, 0], "kind": "teleporter",
        "transform": cols(m.inverse()), "partner": 0,
    }));
    let level = b.level();

    let (eye, look) = ([1.0, 1.2, 2.0], [1.0, 0.0, 0.2]);
    let t = trace(&level, eye, look);
    assert_eq!(t.location, Location::Inside(0));
    let far: Vec<&Visible> = t.visible().iter().filter(|v| v.cell == Some(1)).collect();
    assert_eq!(far.len(), 1, "{:?}", t.visible());
    let draw = far[0].transform.expect("seen through a teleporter");
    assert!(draw.abs_diff_eq(m.inverse(), 1e-9), "{draw}");
    assert!(!far[0].mirrored);
    assert_eq!((far[0].depth, t.via(far[0])), (1, &[0u32][..]));
    let opening = Opening {
        x: 4.0,
        y: [0.0, 2.0],
        z: [1.0, 3.0],
    };
    let n = check_seen(
        &level,
        &t,
        &Cam::new(eye, look),
        1,
        Some(draw),
        &[opening],
        "A to B",
    );
    assert!(n > 50, "{n} points of B seen");
    // A box in B right in front of the exit shows; one in B beside the exit, behind its
    // wall as seen through the teleporter, does not.
    let (i, _) = t
        .visible()
        .iter()
        .enumerate()
        .find(|(_, v)| v.cell == Some(1))
        .unwrap();
    assert!(t.box_visible(i, DVec3::new(11.8, 0.8, 11.0), DVec3::new(12.2, 1.2, 11.4)));
    assert!(!t.box_visible(i, DVec3::new(10.1, 0.5, 10.1), DVec3::new(10.4, 0.8, 10.3)));

    // From B looking back into the exit: A, drawn with the forward transform.
    let t = trace(&level, [12.0, 1.2, 13.0], [0.0, 0.0, -1.0]);
    assert_eq!(t.location, Location::Inside(1));
    let back: Vec<&Visible> = t.visible().iter().filter(|v| v.cell == Some(0)).collect();
    assert_eq!(back.len(), 1);
    assert!(back[0].transform.unwrap().abs_diff_eq(m, 1e-9));
    assert_eq!(t.via(back[0]), [1]);
}

// ---------------------------------------------------------------------------------------------
// 6. Doors

/// A = [0,4] (0), B = [4,8] (1), C = [8,12] (2) along x. The wall x = 4 has two doorways: the
/// middle one (z 1.5..2.5; portals 0/1), on the axis of the doorway B-C (x = 8, z 1.5..2.5;
/// portals 2/3), and a side one (z 3.0..3.8; portals 4/5) from which C is out of sight.
fn doors_level(closed_bc: bool) -> Level {
    let mut b = three_rooms();
    if closed_bc {
        b.portals[2]["closed"] = json!(true);
        b.portals[3]["closed"] = json!(true);
    }
    b.door(0, 1, &rect(0, 4.0, [0.0, 3.0], [2.2, 3.8]));
    b.level()
}

#[test]
fn closing_a_door_hides_what_only_it_showed() {
    let level = doors_level(false);
    let v = view([1.0, 1.1, 2.0], [1.0, 0.0, 0.0]);
    let opts = TraceOptions::default();
    let mut doors = Doors::new(&level);
    assert!((0..6).all(|p| !doors.is_closed(p)));
    let t = trace_with(&level, &doors, &opts, &v);
    assert_eq!(seen(&t), [Some(0), Some(1), Some(2)]);
    assert_eq!(t.stats.closed_skipped, 0);

    // Closing the middle doorway: B is still seen through the side one, C is not.
    doors.set(&level, 0, true);
    assert!(
        doors.is_closed(0) && doors.is_closed(1),
        "the partner closes too"
    );
    let t = trace_with(&level, &doors, &opts, &v);
    assert_eq!(seen(&t), [Some(0), Some(1)]);
    let (_, b) = entry(&t, Some(1)).unwrap();
    assert_eq!(t.via(b), [4]);
    assert!(t.stats.closed_skipped >= 1);

    // Both doorways closed: A alone.
    doors.set(&level, 5, true);
    assert!(doors.is_closed(4));
    let t = trace_with(&level, &doors, &opts, &v);
    assert_eq!(seen(&t), [Some(0)]);
    assert_eq!(t.stats.closed_skipped, 2);

    // Reopened from the other side: everything again.
    doors.set(&level, 1, false);
    doors.set(&level, 4, false);
    assert_eq!(doors, Doors::new(&level));
    let t = trace_with(&level, &doors, &opts, &v);
    assert_eq!(seen(&t), [Some(0), Some(1), Some(2)]);
    // Out-of-range indices are ignored.
    doors.set(&level, 99, true);
    assert_eq!(doors, Doors::new(&level));
}

#[test]
fn an_initially_closed_door_starts_closed_and_opens() {
    let level = doors_level(true);
    let v = view([1.0, 1.1, 2.0], [1.0, 0.0, 0.0]);
    let opts = TraceOptions::default();
    let mut doors = Doors::new(&level);
    assert!(doors.is_closed(2) && doors.is_closed(3));
    assert!(!doors.is_closed(0) && !doors.is_closed(4));
    let t = trace_with(&level, &doors, &opts, &v);
    assert_eq!(seen(&t), [Some(0), Some(1)]);
    assert!(t.stats.closed_skipped >= 1);
    doors.set(&level, 2, false);
    assert!(!doors.is_closed(2) && !doors.is_closed(3));
    let t = trace_with(&level, &doors, &opts, &v);
    assert_eq!(seen(&t), [Some(0), Some(1), Some(2)]);
    let (_, c) = entry(&t, Some(2)).unwrap();
    assert_eq!(t.via(c), [0, 2]);
    // From C looking back, the closed door hid A and B too.
    let back = view([11.0, 1.1, 2.0], [-1.0, 0.0, 0.0]);
    let t = trace_with(&level, &Doors::new(&level), &opts, &back);
    assert_eq!(seen(&t), [Some(2)]);
    let t = trace_with(&level, &doors, &opts, &back);
    assert_eq!(seen(&t), [Some(0), Some(1), Some(2)]);
}

// ---------------------------------------------------------------------------------------------
// 7. One-way portals

#[test]
fn one_way_portal_is_seen_only_from_its_source() {
    // A -> B one way (portal 0, no partner), and a one-way window of B to the outside
    // (portal 1) beside a two-way window (portal 2).
    let mut b = Builder::default();
    b.room("a", [0.0, 0.0, 0.0], [4.0, 3.0, 4.0]);
    b.room("b", [4.0, 0.0, 0.0], [8.0, 3.0, 4.0]);
    let one_way_window = reversed(&rect(0, 8.0, [1.0, 0.5], [2.0, 1.5]));
    let two_way_window = reversed(&rect(0, 8.0, [1.0, 2.5], [2.0, 3.5]));
    b.portal(json!({"polygon": reversed(&door_at(4.0)), "cells": [0, 1], "oneWay": true}));
    b.portal(json!({"polygon": one_way_window, "cells": [1], "oneWay": true}));
    b.portal(json!({"polygon": two_way_window, "cells": [1]}));
    let level = b.level();

    // From A: B, and the outside through B's windows.
    let t = trace(&level, [1.0, 1.1, 2.0], [1.0, 0.0, 0.0]);
    assert_eq!(seen(&t), [None, Some(0), Some(1)]);
    let (_, e) = entry(&t, Some(1)).unwrap();
    assert_eq!(t.via(e), [0]);
    let t = trace(&level, [7.0, 1.1, 2.0], [-1.0, 0.0, 0.0]);
    assert_eq!(
        seen(&t),
        [Some(1)],
        "A is not seen back through a one-way portal"
    );
    // Standing in the doorway on B's side, looking back: still not A.
    let t = trace(&level, [4.0 + 1e-3, 1.1, 2.0], [-1.0, 0.0, 0.0]);
    assert_eq!(t.location, Location::Inside(1));
    assert_eq!(seen(&t), [Some(1)]);

    // From inside B, both windows show the outside.
    let t = trace(&level, [5.0, 1.5, 2.0], [1.0, 0.0, 0.0]);
    assert_eq!(seen(&t), [None, Some(1)]);
    // From outside, looking at the one-way window only (a 20-degree view): B is not seen.
    let t = trace(&level, [10.0, 1.5, 1.0], [-1.0, 0.0, 0.0]);
    assert_eq!(t.location, Location::Outside { nearest: Some(1) });
    let cam = Cam::with([10.0, 1.5, 1.0], [-1.0, 0.0, 0.0], 20.0, 1.0);
    assert!(cam.sees_any(&one_way_window) && !cam.sees_any(&two_way_window));
    // A 20-degree square view from `eye`, looking along -x.
    let narrow = |eye: [f64; 3]| {
        let v = View::new(eye, [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], 20.0, 1.0, NEAR).unwrap();
        trace_with(&level, &Doors::new(&level), &TraceOptions::default(), &v)
    };
    let t = narrow([10.0, 1.5, 1.0]);
    assert_eq!(seen(&t), [None], "the one-way window hides B from outside");
    // ...while the two-way window shows it.
    let cam = Cam::with([10.0, 1.5, 3.0], [-1.0, 0.0, 0.0], 20.0, 1.0);
    assert!(!cam.sees_any(&one_way_window) && cam.sees_any(&two_way_window));
    let t = narrow([10.0, 1.5, 3.0]);
    assert_eq!(seen(&t), [None, Some(1)]);
    let (_, e) = entry(&t, Some(1)).unwrap();
    assert_eq!(t.via(e), [2]);
}

// ---------------------------------------------------------------------------------------------
// 8. The stored PVS as a prefilter

#[test]
fn stored_pvs_prefilters_the_trace() {
    // The PVS says A does not see C, though the aligned doorways show it.
    let mut b = three_rooms();
    b.pvs(json!([[0, 1], [0, 1, 2], [1, 2]]));
    let level = b.level();
    assert!(!level.pvs_sees(0, 2) && level.pvs_sees(1, 2));
    let v = view([1.0, 1.1, 2.0], [1.0, 0.0, 0.0]);
    let doors = Doors::new(&level);
    let t = trace_with(&level, &doors, &TraceOptions::default(), &v);
    assert_eq!(t.location, Location::Inside(0));
    assert_eq!(seen(&t), [Some(0), Some(1)]);
    assert_eq!(t.stats.pvs_skipped, 1);
    let no_pvs = TraceOptions {
        use_pvs: false,
        ..TraceOptions::default()
    };
    let t = trace_with(&level, &doors, &no_pvs, &v);
    assert_eq!(seen(&t), [Some(0), Some(1), Some(2)]);
    assert_eq!(t.stats.pvs_skipped, 0);
    // The same level without a stored PVS traces C.
    let t = trace(&three_rooms().level(), [1.0, 1.1, 2.0], [1.0, 0.0, 0.0]);
    assert_eq!(seen(&t), [Some(0), Some(1), Some(2)]);
}

// ---------------------------------------------------------------------------------------------
// 9. The outside

/// Room 1 = [0,4]x[0,3]x[0,4] (cell 0) with a window in x = 4 (portal 0), room 2 =
/// [8,12]x[0,3]x[0,4] (cell 1) with a window in x = 8 (portal 1) facing it across open
/// ground; both windows y 1..2, z 1..3.
fn two_houses() -> Level {
    let mut b = Builder::default();
    b.room("one", [0.0, 0.0, 0.0], [4.0, 3.0, 4.0]);
    b.room("two", [8.0, 0.0, 0.0], [12.0, 3.0, 4.0]);
    b.portal(json!({"polygon": reversed(&rect(0, 4.0, [1.0, 1.0], [2.0, 3.0])), "cells": [0]}));
    b.portal(json!({"polygon": rect(0, 8.0, [1.0, 1.0], [2.0, 3.0]), "cells": [1]}));
    b.level()
}

#[test]
fn looking_out_of_a_window_into_another_house() {
    let level = two_houses();
    assert_eq!(level.portal_cells(0), (0, None));
    let t = trace(&level, [1.0, 1.5, 2.0], [1.0, 0.0, 0.0]);
    assert_eq!(t.location, Location::Inside(0));
    assert_eq!(seen(&t), [None, Some(0), Some(1)]);
    let (_, out) = entry(&t, None).unwrap();
    assert_eq!((out.depth, t.via(out)), (1, &[0u32][..]));
    let (_, two) = entry(&t, Some(1)).unwrap();
    assert_eq!((two.depth, t.via(two)), (2, &[0u32, 1][..]));
    // Turned away from the window: room 1 alone.
    let t = trace(&level, [1.0, 1.5, 2.0], [-1.0, 0.0, 0.0]);
    assert_eq!(seen(&t), [Some(0)]);

    // Points in no cell: outside, with the nearest cell.
    assert_eq!(
        level.locate(DVec3::new(5.0, 1.5, 2.0), None),
        Location::Outside { nearest: Some(0) }
    );
    assert_eq!(
        level.locate(DVec3::new(7.5, 1.5, 2.0), Some(0)),
        Location::Outside { nearest: Some(1) }
    );
    assert_eq!(
        level.locate(DVec3::new(2.0, 10.0, 2.0), None),
        Location::Outside { nearest: Some(0) }
    );
    assert_eq!(
        level.locate(DVec3::new(30.0, -5.0, -7.0), Some(0)),
        Location::Outside { nearest: Some(1) }
    );
    // A camera outside sees the outside and, through each window, its room.
    let t = trace(&level, [5.5, 1.5, 2.0], [1.0, 0.0, 0.0]);
    assert_eq!(t.location, Location::Outside { nearest: Some(0) });
    assert_eq!(seen(&t), [None, Some(1)]);
    let (_, two) = entry(&t, Some(1)).unwrap();
    assert_eq!(t.via(two), [1]);
    let t = trace(&level, [5.5, 1.5, 2.0], [-1.0, 0.0, 0.0]);
    assert_eq!(seen(&t), [None, Some(0)]);
}

#[test]
fn random_cameras_around_two_houses_miss_nothing() {
    let level = two_houses();
    let window = |x: f64| Opening {
        x,
        y: [1.0, 2.0],
        z: [1.0, 3.0],
    };
    let mut rng = Lcg(11);
    let (mut from_inside, mut from_outside) = (0, 0);
    for n in 0..1500 {
        let outside = n % 2 == 1;
        let eye = if outside {
            [
                rng.range(4.1, 7.9),
                rng.range(0.3, 2.7),
                rng.range(-1.0, 5.0),
            ]
        } else {
            [
                rng.range(0.05, 3.95),
                rng.range(0.3, 2.7),
                rng.range(0.05, 3.95),
            ]
        };
        let look = [
            rng.range(-1.0, 1.0),
            rng.range(-0.4, 0.4),
            rng.range(-1.0, 1.0),
        ];
        if look[0].abs() < 0.05 && look[2].abs() < 0.05 {
            continue;
        }
        let t = trace(&level, eye, look);
        let cam = Cam::new(eye, look);
        let label = format!("camera {n}: eye {eye:?} look {look:?}");
        if outside {
            assert!(matches!(t.location, Location::Outside { .. }), "{label}");
            from_outside += check_seen_through(&level, &t, &cam, 0, &[window(4.0)], &label);
            from_outside += check_seen_through(&level, &t, &cam, 1, &[window(8.0)], &label);
        } else {
            assert_eq!(t.location, Location::Inside(0), "{label}");
            let through = [window(4.0), window(8.0)];
            from_inside += check_seen_through(&level, &t, &cam, 1, &through, &label);
            if let Some((_, two)) = entry(&t, Some(1)) {
                assert_eq!(t.via(two), [0, 1], "{label}");
            }
        }
    }
    assert!(
        from_inside > 10 && from_outside > 1000,
        "{from_inside} {from_outside}"
    );
}

#[test]
fn the_shallowest_path_names_the_entry() {
    // A = [0,4]x[0,4] (z), C = [0,4]x[4,8] beside it, B = [4,8]x[0,8] along both. Doorways:
    // A-C in z = 4 (portals 0/1), C-B in x = 4 at z 5..7 (2/3), A-B in x = 4 at z 1.5..2.5
    // (4/5). From A, B is reached first through C (depth 2), then directly (depth 1).
    let mut b = Builder::default();
    b.room("a", [0.0, 0.0, 0.0], [4.0, 3.0, 4.0]);
    b.room("c", [0.0, 0.0, 4.0], [4.0, 3.0, 8.0]);
    b.room("b", [4.0, 0.0, 0.0], [8.0, 3.0, 8.0]);
    b.door(0, 1, &rect(2, 4.0, [1.0, 0.0], [2.5, 2.2]));
    b.door(1, 2, &rect(0, 4.0, [0.0, 5.0], [2.2, 7.0]));
    b.door(0, 2, &door_at(4.0));
    let level = b.level();
    let t = trace(&level, [0.5, 1.5, 0.5], [1.0, 0.0, 1.0]);
    assert_eq!(seen(&t), [Some(0), Some(1), Some(2)]);
    let (_, c) = entry(&t, Some(1)).unwrap();
    assert_eq!(t.via(c), [0]);
    let (i, b_entry) = entry(&t, Some(2)).unwrap();
    assert_eq!((b_entry.depth, t.via(b_entry)), (1, &[4u32][..]));
    assert_eq!(t.stats.deepest, 2, "B was also entered through C");
    // Both paths count for objects: a box in B seen only through C, and one seen only
    // through the direct doorway.
    let cam = Cam::new([0.5, 1.5, 0.5], [1.0, 0.0, 1.0]);
    let via_c = DVec3::new(4.3, 1.5, 7.35);
    let direct = DVec3::new(5.0, 1.5, 2.5);
    assert!(cam.ndc(via_c, 0.0).is_some() && cam.ndc(direct, 0.0).is_some());
    // (Through C: x 1..2.5 at z = 4 and z 5..7 at x = 4 leave directions dx/dz 0.538..0.571.)
    let h = DVec3::splat(0.02);
    assert!(t.box_visible(i, via_c - h, via_c + h));
    assert!(t.box_visible(i, direct - h, direct + h));
    // Seen neither way: behind the wall between the two doorways.
    let hidden = DVec3::new(6.0, 1.5, 5.0);
    assert!(cam.ndc(hidden, 0.0).is_some());
    assert!(!t.box_visible(i, hidden - h, hidden + h));
    // The rectangle is the union of both paths'.
    for p in [via_c, direct] {
        let [x, y] = cam.ndc(p, 0.0).unwrap();
        let r = b_entry.rect;
        assert!(
            x >= r[0] && x <= r[2] && y >= r[1] && y <= r[3],
            "{p}: {r:?}"
        );
    }
}

#[test]
fn far_from_the_origin_the_same_answers() {
    // 2^20 m out on x and z (the runtime keeps f64 throughout).
    let o = [1_048_576.0, 0.0, -1_048_576.0];
    let ov = DVec3::from(o);
    let at = |p: [f64; 3]| (DVec3::from(p) + ov).to_array();
    let level = shifted(&two_rooms(), o).level();
    let door = Opening {
        x: 4.0 + o[0],
        y: [0.0, 2.2],
        z: [1.5 + o[2], 2.5 + o[2]],
    };
    for s in [-2.0 * NEAR, -1e-3, 0.0, 1e-3, 2.0 * NEAR] {
        for look in LOOKS {
            let eye = at([4.0 + s, 1.1, 2.0]);
            let t = trace(&level, eye, look);
            let own = t.location.cell().unwrap();
            if s != 0.0 {
                assert_eq!(own, usize::from(s > 0.0));
            }
            let label = format!("s {s} look {look:?}");
            check_seen_through(&level, &t, &Cam::new(eye, look), 1 - own, &[door], &label);
        }
        let t = trace(
            &level,
            at([4.0 + s, 1.1, 2.0]),
            [if s > 0.0 { -1.0 } else { 1.0 }, 0.0, 0.0],
        );
        assert_eq!(seen(&t), [Some(0), Some(1)], "s {s}");
    }
    assert_eq!(
        level.locate(DVec3::from(at([4.0 - 1e-7, 1.0, 2.0])), Some(1)),
        Location::Boundary(1)
    );
    assert_eq!(
        level.locate(DVec3::from(at([2.0, 1.0, 2.0])), None),
        Location::Inside(0)
    );

    // The facing mirrors: the same images, conjugated by the shift.
    let mut b = Builder::default();
    b.room("hall", [0.0, 0.0, 0.0], [4.0, 3.0, 4.0]);
    b.portal(json!({
        "polygon": rect(0, 0.0, [0.0, 0.0], [3.0, 4.0]), "cells": [0, 0], "kind": "mirror",
        "transform": cols(reflection_x(0.0)), "partner": 0,
    }));
    b.portal(json!({
        "polygon": reversed(&rect(0, 4.0, [0.0, 0.0], [3.0, 4.0])), "cells": [0, 0],
        "kind": "mirror", "transform": cols(reflection_x(4.0)), "partner": 1,
    }));
    let level = shifted(&b, o).level();
    let t = trace(&level, at([1.0, 1.5, 2.0]), [1.0, 0.0, 0.0]);
    assert_eq!(t.visible().len(), 3, "{:?}", t.visible());
    for (i, e) in t.visible().iter().enumerate().skip(1) {
        let expect = translation(o[0], o[1], o[2]) * image(i) * translation(-o[0], -o[1], -o[2]);
        assert!(e.transform.unwrap().abs_diff_eq(expect, 1e-6), "image {i}");
        assert_eq!(e.mirrored, i % 2 == 1);
    }

    // Nested rooms: the inner one still wins.
    let mut b = Builder::default();
    b.room("big", [0.0, 0.0, 0.0], [10.0, 10.0, 10.0]);
    b.room("small", [4.0, 4.0, 4.0], [6.0, 6.0, 6.0]);
    let nested = shifted(&b, o).level();
    for hint in [None, Some(0), Some(1)] {
        assert_eq!(
            nested.locate(DVec3::from(at([5.0, 5.0, 5.0])), hint),
            Location::Inside(1)
        );
        assert_eq!(
            nested.locate(DVec3::from(at([1.0, 1.0, 1.0])), hint),
            Location::Inside(0)
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 10. Moving objects

#[test]
fn moving_objects_find_their_cells_and_are_culled_behind_walls() {
    let level = two_rooms().level();
    let mut cells = Vec::new();
    level.cells_touching(
        DVec3::new(3.8, 0.5, 1.8),
        DVec3::new(4.2, 1.5, 2.2),
        &mut cells,
    );
    assert_eq!(cells, [0, 1], "straddling the doorway");
    level.cells_touching(
        DVec3::new(1.0, 0.5, 1.0),
        DVec3::new(2.0, 1.5, 2.0),
        &mut cells,
    );
    assert_eq!(cells, [0]);
    level.cells_touching(
        DVec3::new(6.0, 0.0, 3.0),
        DVec3::new(7.9, 1.0, 3.9),
        &mut cells,
    );
    assert_eq!(cells, [1]);
    level.cells_touching(
        DVec3::new(20.0, 0.0, 0.0),
        DVec3::new(21.0, 1.0, 1.0),
        &mut cells,
    );
    assert!(cells.is_empty());

    let t = trace(&level, [1.0, 1.1, 2.0], [1.0, 0.0, 0.0]);
    let (i, _) = entry(&t, Some(1)).unwrap();
    // In view through the doorway.
    assert!(t.box_visible(i, DVec3::new(5.5, 0.8, 1.8), DVec3::new(6.0, 1.3, 2.2)));
    // In the frustum, but behind the wall beside the doorway (z < 1.5 just past x = 4).
    let (lo, hi) = (DVec3::new(4.2, 0.5, 0.2), DVec3::new(4.6, 1.0, 0.6));
    let cam = Cam::new([1.0, 1.1, 2.0], [1.0, 0.0, 0.0]);
    assert!(cam.ndc(lo, 0.0).is_some() && cam.ndc(hi, 0.0).is_some());
    assert!(!t.box_visible(i, lo, hi));
    // The same box is within room A's view (the frustum), which draws nothing of B.
    assert!(t.box_visible(0, lo, hi));
    // Out of range entries see nothing.
    assert!(!t.box_visible(t.visible().len(), lo, hi));
}

// ---------------------------------------------------------------------------------------------
// 11. Locate

#[test]
fn locate_inside_on_a_boundary_and_in_nested_rooms() {
    let level = two_rooms().level();
    assert_eq!(
        level.locate(DVec3::new(1.0, 1.0, 1.0), None),
        Location::Inside(0)
    );
    assert_eq!(
        level.locate(DVec3::new(6.0, 1.0, 1.0), Some(0)),
        Location::Inside(1),
        "a wrong hint is not trusted"
    );
    // 1e-7 from the shared wall (tolerance 1e-5): on the boundary of both; the hint decides.
    for p in [
        DVec3::new(4.0 - 1e-7, 1.0, 2.0),
        DVec3::new(4.0 + 1e-7, 1.0, 2.0),
        DVec3::new(4.0 - 1e-7, 1.0, 0.5),
    ] {
        assert_eq!(level.locate(p, Some(0)), Location::Boundary(0), "{p}");
        assert_eq!(level.locate(p, Some(1)), Location::Boundary(1), "{p}");
        assert!(matches!(level.locate(p, None), Location::Boundary(0 | 1)));
    }
    // On an outer wall: the boundary of its only cell; beyond the tolerance: outside.
    assert_eq!(
        level.locate(DVec3::new(8.0 + 1e-7, 1.0, 2.0), None),
        Location::Boundary(1)
    );
    assert_eq!(
        level.locate(DVec3::new(8.0 + 1e-3, 1.0, 2.0), Some(1)),
        Location::Outside { nearest: Some(1) }
    );
    // A camera on the boundary traces from the hinted cell.
    let v = view([4.0 - 1e-7, 1.1, 2.0], [1.0, 0.0, 0.0]);
    let mut t = Trace::default();
    t.location = Location::Inside(1);
    level.trace(&v, &Doors::new(&level), &TraceOptions::default(), &mut t);
    assert_eq!(t.location, Location::Boundary(1));
    assert_eq!(t.visible()[0].cell, Some(1));

    // A small room nested in a big one: the inner cell wins, whatever the hint.
    let mut b = Builder::default();
    b.room("big", [0.0, 0.0, 0.0], [10.0, 10.0, 10.0]);
    b.room("small", [4.0, 4.0, 4.0], [6.0, 6.0, 6.0]);
    let nested = b.level();
    let inner = DVec3::new(5.0, 5.0, 5.0);
    for hint in [None, Some(0), Some(1), Some(7)] {
        assert_eq!(nested.locate(inner, hint), Location::Inside(1), "{hint:?}");
        assert_eq!(
            nested.locate(DVec3::new(1.0, 1.0, 1.0), hint),
            Location::Inside(0),
            "{hint:?}"
        );
        assert_eq!(
            nested.locate(DVec3::new(5.0, 5.0, 8.0), hint),
            Location::Inside(0),
            "{hint:?}"
        );
    }
    let mut cells = Vec::new();
    nested.cells_touching(
        DVec3::new(4.5, 4.5, 4.5),
        DVec3::new(5.0, 5.0, 5.0),
        &mut cells,
    );
    assert_eq!(cells, [0, 1]);

    // Issue 29, item 8: a stored priority decides before size. The big room given the
    // higher priority holds the point in the small one too; equal priorities fall back to
    // the smaller cell.
    let mut b = Builder::default();
    b.room("big", [0.0, 0.0, 0.0], [10.0, 10.0, 10.0]);
    b.room("small", [4.0, 4.0, 4.0], [6.0, 6.0, 6.0]);
    b.cells[0]["priority"] = json!(2);
    let ranked = b.level();
    for hint in [None, Some(0), Some(1)] {
        assert_eq!(ranked.locate(inner, hint), Location::Inside(0), "{hint:?}");
    }
    b.cells[1]["priority"] = json!(2);
    assert_eq!(b.level().locate(inner, None), Location::Inside(1));
}

/// An eye in a thick wall's doorway stands in no cell and sees the rooms on both sides with
/// the whole view, even where one of them was reached first through a narrower opening: here
/// room A, 15 cm behind the eye, through a window in the same wall seen from outside. A = [0,4]
/// x [0,3] x [0,8] (cell 0), B = [4.3,8.3] x [0,3] x [0,4] (cell 1), a 30 cm wall between them
/// with a doorway (z 1.5..2.5, y 0..2.2; portals 0 and 1) and, further along A's side of it,
/// a window to the outside (z 5..7, y 1..2; portal 2).
#[test]
fn an_eye_in_a_thick_doorway_sees_both_rooms_whole_though_one_shows_through_a_window() {
    let mut b = Builder::default();
    let a = b.room("A", [0.0, 0.0, 0.0], [4.0, 3.0, 8.0]);
    let c = b.room("B", [4.3, 0.0, 0.0], [8.3, 3.0, 4.0]);
    let near_side = facing(&rect(0, 4.0, [0.0, 1.5], [2.2, 2.5]), b.centre(a));
    let far_side = facing(&rect(0, 4.3, [0.0, 1.5], [2.2, 2.5]), b.centre(c));
    b.portal(json!({"polygon": near_side, "cells": [a, c], "partner": 1}));
    b.portal(json!({"polygon": far_side, "cells": [c, a], "partner": 0}));
    let window = facing(&rect(0, 4.0, [1.0, 5.0], [2.0, 7.0]), b.centre(a));
    b.portal(json!({"polygon": window, "cells": [a]}));
    let level = b.level();
    // Looking along the wall towards the window: it is in view, from outside.
    let t = trace(&level, [4.15, 1.5, 2.0], [-0.3, 0.0, 1.0]);
    assert!(t.location.cell().is_none(), "{:?}", t.location);
    for cell in [a, c] {
        let (_, v) =
            entry(&t, Some(cell)).unwrap_or_else(|| panic!("cell {cell}: {:?}", t.visible()));
        assert_eq!(v.rect, [-1.0, -1.0, 1.0, 1.0], "cell {cell}: {v:?}");
    }
}

/// An eye on a wall of no thickness, a metre from the doorway in it, stands on both rooms'
/// boundaries: whichever it is located in, it sees into the other with the whole view (its
/// near plane lies there, and the doorway is edge-on), looking either way.
#[test]
fn an_eye_on_a_wall_of_no_thickness_sees_the_room_it_looks_into() {
    let level = two_rooms().level();
    for look in [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]] {
        let t = trace(&level, [4.0, 1.5, 3.5], look);
        assert!(
            matches!(t.location, Location::Boundary(_)),
            "{:?}",
            t.location
        );
        for cell in [0, 1] {
            let (_, v) = entry(&t, Some(cell))
                .unwrap_or_else(|| panic!("{look:?}: cell {cell}: {:?}", t.visible()));
            assert_eq!(
                v.rect,
                [-1.0, -1.0, 1.0, 1.0],
                "{look:?}: cell {cell}: {v:?}"
            );
        }
    }
}

/// A near plane a metre out puts every portal of a grid of small rooms within its reach, so
/// each is passed through with the whole view: the walk must enter each room a bounded number
/// of times, not once per simple path among them (a brush map's small cells ran a trace out
/// of memory). Rooms 0.5 m square in a 4 x 4 grid, every neighbour open through a whole face.
#[test]
fn a_near_plane_reaching_many_portals_walks_each_room_a_bounded_number_of_times() {
    let mut b = Builder::default();
    let n = 4;
    let s = 0.5;
    let id = |i: usize, k: usize| i * n + k;
    for i in 0..n {
        for k in 0..n {
            let (x, z) = (i as f64 * s, k as f64 * s);
            b.room(&format!("r{i}_{k}"), [x, 0.0, z], [x + s, 3.0, z + s]);
        }
    }
    for i in 0..n {
        for k in 0..n {
            let (x, z) = (i as f64 * s, k as f64 * s);
            if i + 1 < n {
                b.door(
                    id(i, k),
                    id(i + 1, k),
                    &rect(0, x + s, [0.0, z], [3.0, z + s]),
                );
            }
            if k + 1 < n {
                b.door(
                    id(i, k),
                    id(i, k + 1),
                    &rect(2, z + s, [x, 0.0], [x + s, 3.0]),
                );
            }
        }
    }
    let level = b.level();
    let v = View::new(
        [0.8, 1.5, 0.8],
        [1.0, 0.0, 0.3],
        [0.0, 1.0, 0.0],
        FOV,
        ASPECT,
        1.0,
    )
    .unwrap();
    let t = trace_with(&level, &Doors::new(&level), &TraceOptions::default(), &v);
    assert_eq!(seen(&t).len(), n * n, "every room: {:?}", seen(&t));
    assert!(
        t.stats.entered as usize <= 8 * n * n,
        "{} rooms entered {} times",
        n * n,
        t.stats.entered
    );
}
