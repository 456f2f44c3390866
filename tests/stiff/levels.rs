//! Builders for the stiff levels of `tests/stiff.rs`: axis-aligned box rooms with rectangular
//! holes, written as OBJ text (decimal, so every coordinate is exactly what the test chose), and
//! scenes built in code for the cases that need extras (mirrors, teleporters).
#![allow(dead_code)]

use glam::DVec3;

/// One face of a box room.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Face {
    X0,
    X1,
    Y0,
    Y1,
    Z0,
    Z1,
}

/// A rectangular hole in a face, in the face's (u, v) coordinates: x faces use (z, y), z faces
/// (x, y), y faces (x, z).
#[derive(Clone, Copy, Debug)]
pub struct Hole {
    pub face: Face,
    pub u0: f64,
    pub u1: f64,
    pub v0: f64,
    pub v1: f64,
}

pub fn hole(face: Face, u0: f64, u1: f64, v0: f64, v1: f64) -> Hole {
    Hole {
        face,
        u0,
        u1,
        v0,
        v1,
    }
}

fn point(face: Face, c: f64, u: f64, v: f64) -> DVec3 {
    match face {
        Face::X0 | Face::X1 => DVec3::new(c, v, u),
        Face::Y0 | Face::Y1 => DVec3::new(u, c, v),
        Face::Z0 | Face::Z1 => DVec3::new(u, v, c),
    }
}

/// Two triangles of the quad a-b-c-d, wound so their normal points along `facing`.
pub fn quad(a: DVec3, b: DVec3, c: DVec3, d: DVec3, facing: DVec3) -> Vec<[DVec3; 3]> {
    let n = (b - a).cross(c - a) + (c - a).cross(d - a);
    if n.dot(facing) >= 0.0 {
        vec![[a, b, c], [a, c, d]]
    } else {
        vec![[a, c, b], [a, d, c]]
    }
}

/// The rectangle [u0, u1] x [v0, v1] of the plane of `face` at `c`, minus `holes`, tiled by
/// rectangles on the grid of every hole edge, facing `facing`.
pub fn tiled(
    face: Face,
    c: f64,
    (u0, u1, v0, v1): (f64, f64, f64, f64),
    holes: &[Hole],
    facing: DVec3,
) -> Vec<[DVec3; 3]> {
    let mut us = vec![u0, u1];
    let mut vs = vec![v0, v1];
    for h in holes {
        us.extend([h.u0, h.u1]);
        vs.extend([h.v0, h.v1]);
    }
    for x in [&mut us, &mut vs] {
        x.sort_by(f64::total_cmp);
        x.dedup();
    }
    let mut out = Vec::new();
    for i in 0..us.len() - 1 {
        for j in 0..vs.len() - 1 {
            let (a, b, p, q) = (us[i], us[i + 1], vs[j], vs[j + 1]);
            if a < u0 || b > u1 || p < v0 || q > v1 {
                continue;
            }
            let (mu, mv) = ((a + b) / 2.0, (p + q) / 2.0);
            if holes
                .iter()
                .any(|h| h.u0 < mu && mu < h.u1 && h.v0 < mv && mv < h.v1)
            {
                continue;
            }
            out.extend(quad(
                point(face, c, a, p),
                point(face, c, b, p),
                point(face, c, b, q),
                point(face, c, a, q),
                facing,
            ));
        }
    }
    out
}

/// The inward-facing floor, ceiling and walls of the box [min, max], with `holes` cut out;
/// faces listed in `open` are left out entirely.
pub fn box_room(min: DVec3, max: DVec3, holes: &[Hole], open: &[Face]) -> Vec<[DVec3; 3]> {
    let mut out = Vec::new();
    for (face, c, rect, facing) in [
        (Face::X0, min.x, (min.z, max.z, min.y, max.y), DVec3::X),
        (Face::X1, max.x, (min.z, max.z, min.y, max.y), -DVec3::X),
        (Face::Y0, min.y, (min.x, max.x, min.z, max.z), DVec3::Y),
        (Face::Y1, max.y, (min.x, max.x, min.z, max.z), -DVec3::Y),
        (Face::Z0, min.z, (min.x, max.x, min.y, max.y), DVec3::Z),
        (Face::Z1, max.z, (min.x, max.x, min.y, max.y), -DVec3::Z),
    ] {
        if open.contains(&face) {
            continue;
        }
        let hs: Vec<Hole> = holes.iter().copied().filter(|h| h.face == face).collect();
        out.extend(tiled(face, c, rect, &hs, facing));
    }
    out
}

/// Mesh objects of an OBJ level, by node path.
#[derive(Default)]
pub struct ObjLevel {
    pub objects: Vec<(String, Vec<[DVec3; 3]>)>,
    /// Write every vertex twice and use both copies (duplicate vertices).
    pub duplicate_vertices: bool,
}

impl ObjLevel {
    pub fn add(&mut self, path: impl Into<String>, tris: Vec<[DVec3; 3]>) -> &mut Self {
        self.objects.push((path.into(), tris));
        self
    }

    /// A room `name` (Godot suffix `-room`) with its surfaces as one `Walls` object.
    pub fn room(&mut self, name: &str, tris: Vec<[DVec3; 3]>) -> &mut Self {
        self.add(format!("Level/{name}-room/Walls"), tris)
    }

    /// OBJ text; coordinates are written with Rust's shortest round-trip formatting, so they
    /// read back as exactly the same f64.
    pub fn text(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let mut next = 1usize;
        for (name, tris) in &self.objects {
            writeln!(s, "o {name}").unwrap();
            for t in tris {
                for p in t {
                    writeln!(s, "v {} {} {}", p.x, p.y, p.z).unwrap();
                    if self.duplicate_vertices {
                        writeln!(s, "v {} {} {}", p.x, p.y, p.z).unwrap();
                    }
                }
                if self.duplicate_vertices {
                    // Mixed copies: the first vertex from the first copy, the others from the
                    // second.
                    writeln!(s, "f {} {} {}", next, next + 3, next + 5).unwrap();
                    next += 6;
                } else {
                    writeln!(s, "f {} {} {}", next, next + 1, next + 2).unwrap();
                    next += 3;
                }
            }
        }
        s
    }
}
