//! Checks of the test oracle's .map reader (tests/common/map.rs): small brushes written in
//! each face format, and, when `ERICW_TESTMAPS` names ericw-tools' testmaps folder, real maps.

mod common;

use common::map::{parse, to_y_up_metres, Brush, Entity};
use glam::DVec3;

/// Volume by the divergence theorem.
fn volume(b: &Brush) -> f64 {
    b.triangles
        .iter()
        .map(|t| t[0].dot(t[1].cross(t[2])))
        .sum::<f64>()
        / 6.0
}

fn centre(b: &Brush) -> DVec3 {
    let n = b.triangles.len() as f64 * 3.0;
    b.triangles.iter().flatten().copied().sum::<DVec3>() / n
}

/// Every triangle's normal points away from the brush's centre (the brushes are convex) and
/// along its face's outward plane normal.
fn assert_outward(b: &Brush) {
    let c = centre(b);
    for t in &b.triangles {
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        let mid = (t[0] + t[1] + t[2]) / 3.0;
        assert!(
            n.dot(mid - c) > 0.0,
            "brush at line {}: triangle {t:?} faces inwards",
            b.line
        );
    }
    for (poly, f) in &b.polygons {
        let face = &b.faces[*f];
        for k in 1..poly.len() - 1 {
            let n = (poly[k] - poly[0]).cross(poly[k + 1] - poly[0]).normalize();
            assert!(
                n.dot(face.normal) > 1.0 - 1e-9,
                "brush at line {}: face {f} wound against its normal",
                b.line
            );
        }
        for p in poly {
            // On the plane, but for vertices merged with another within 1e-5.
            let d = face.normal.dot(*p) - face.dist;
            assert!(
                d.abs() < 1e-5,
                "brush at line {}: {p} off face {f} by {d}",
                b.line
            );
        }
    }
}

/// Problems with a brush's surface being closed: after matching vertices within 1e-6, every
/// undirected edge must be used by exactly two triangles, once in each direction.
fn closure_problems(b: &Brush) -> Vec<String> {
    let mut verts: Vec<DVec3> = Vec::new();
    let mut index = |p: DVec3| {
        if let Some(i) = verts.iter().position(|v| v.distance(p) < 1e-6) {
            i
        } else {
            verts.push(p);
            verts.len() - 1
        }
    };
    let mut edges: std::collections::BTreeMap<(usize, usize), (u32, u32)> = Default::default();
    let mut problems = Vec::new();
    for t in &b.triangles {
        let ix = [index(t[0]), index(t[1]), index(t[2])];
        for k in 0..3 {
            let (a, c) = (ix[k], ix[(k + 1) % 3]);
            if a == c {
                problems.push(format!("degenerate edge at {}", t[k]));
                continue;
            }
            let e = edges.entry((a.min(c), a.max(c))).or_default();
            if a < c {
                e.0 += 1;
            } else {
                e.1 += 1;
            }
        }
    }
    for ((a, c), (fwd, back)) in edges {
        if (fwd, back) != (1, 1) {
            problems.push(format!(
                "edge {:?}-{:?} used {fwd} times forwards, {back} backwards",
                verts[a], verts[c]
            ));
        }
    }
    problems
}

/// A 64 x 32 x 16 box from (-16, -8, 4), so that a mixed-up axis changes the answer.
const LO: DVec3 = DVec3::new(-16.0, -8.0, 4.0);
const HI: DVec3 = DVec3::new(48.0, 24.0, 20.0);
const BOX_VOLUME: f64 = 64.0 * 32.0 * 16.0;

/// The six faces of the box as three points each, wound as qbsp wants them: with
/// `(p0 - p1) × (p2 - p1)` along the outward normal. Order: -X, +X, -Y, +Y, -Z, +Z.
fn box_points() -> Vec<[DVec3; 3]> {
    let mut out = Vec::new();
    for n in [
        -DVec3::X,
        DVec3::X,
        -DVec3::Y,
        DVec3::Y,
        -DVec3::Z,
        DVec3::Z,
    ] {
        let on = if n.min_element() < 0.0 { LO } else { HI };
        let c = n.abs() * on; // a point of the plane, on the axis
        let a = n.any_orthonormal_vector();
        let b = n.cross(a); // a × b = n
        out.push([c + a * 64.0, c, c + b * 64.0]);
    }
    out
}

fn pts(p: &[DVec3; 3]) -> String {
    p.iter()
        .map(|v| format!("( {} {} {} )", v.x, v.y, v.z))
        .collect::<Vec<_>>()
        .join(" ")
}

const TEXTURES: [&str; 6] = [
    "*water1",
    "+0button",
    "e1u1/floor1_3",
    "#lava",
    "{grate",
    "sky1",
];

fn box_map(face: impl Fn(usize, &[DVec3; 3]) -> String) -> String {
    let faces: Vec<String> = box_points()
        .iter()
        .enumerate()
        .map(|(i, p)| face(i, p))
        .collect();
    format!(
        "// Game: Quake\n{{\n\"classname\" \"worldspawn\" // a comment\n{{\n{}\n}}\n}}\n",
        faces.join("\n")
    )
}

fn check_box(map: &str, what: &str) {
    let ents = parse(map).unwrap_or_else(|e| panic!("{what}: {e}\n{map}"));
    assert_eq!(ents.len(), 1, "{what}");
    assert_eq!(ents[0].classname(), "worldspawn");
    assert_eq!(ents[0].brushes.len(), 1, "{what}");
    let b = &ents[0].brushes[0];
    assert_eq!(b.line, 4, "{what}: the brush's '{{' line");
    assert_eq!(b.faces.len(), 6, "{what}");
    assert_eq!(b.polygons.len(), 6, "{what}");
    assert_eq!(b.triangles.len(), 12, "{what}");
    for (f, tex) in b.faces.iter().zip(TEXTURES) {
        assert_eq!(f.texture, tex, "{what}");
    }
    let expect_normals = [
        -DVec3::X,
        DVec3::X,
        -DVec3::Y,
        DVec3::Y,
        -DVec3::Z,
        DVec3::Z,
    ];
    for (f, n) in b.faces.iter().zip(expect_normals) {
        assert!(f.normal.abs_diff_eq(n, 1e-12), "{what}: {f:?} vs {n}");
    }
    assert!(
        (volume(b) - BOX_VOLUME).abs() < 1e-6,
        "{what}: {}",
        volume(b)
    );
    assert_outward(b);
    assert!(
        closure_problems(b).is_empty(),
        "{what}: {:?}",
        closure_problems(b)
    );
    for t in &b.triangles {
        for p in t {
            assert!(p.cmpge(LO - 1e-9).all() && p.cmple(HI + 1e-9).all());
        }
    }
    let mid = (LO + HI) / 2.0;
    assert!(b.contains(mid, 0.0));
    assert!(b.contains(DVec3::new(47.0, 23.0, 19.0), 0.5));
    assert!(!b.contains(DVec3::new(47.0, 23.0, 19.0), 1.5));
    assert!(
        !b.contains(DVec3::new(48.0, 0.0, 10.0), 0.0),
        "on a face is not inside"
    );
    assert!(!b.contains(DVec3::new(49.0, 0.0, 10.0), 0.0));
}

#[test]
fn a_box_in_each_format() {
    let quake = box_map(|i, p| format!("{} {} 0 0 0 1 1", pts(p), TEXTURES[i]));
    check_box(&quake, "Quake standard");

    let valve = box_map(|i, p| {
        format!(
            "{} {} [ 1 0 0 -1.5e-3 ] [ 0 -1 0 0 ] 0 1 1",
            pts(p),
            TEXTURES[i]
        )
    });
    check_box(&valve, "Valve 220");

    let quake2 = box_map(|i, p| format!("{} {} 16 -32 0 1 1 1 0 0", pts(p), TEXTURES[i]));
    check_box(&quake2, "Quake 2");

    let quake2_valve = box_map(|i, p| {
        format!(
            "{} {} [ 1 0 0 0 ] [ 0 -1 0 0 ] 0 1 1 0 8 0",
            pts(p),
            TEXTURES[i]
        )
    });
    check_box(&quake2_valve, "Quake 2 (Valve)");

    // Formats mixed face by face, negative zeros and exponents as some tools write them.
    let mixed = box_map(|i, p| match i % 3 {
        0 => format!("{} {} -0 -0 -0 1e0 1.0E+0", pts(p), TEXTURES[i]),
        1 => format!("{} {} [ 0 1 0 0 ] [ 0 0 -1 0 ] 0 1 1", pts(p), TEXTURES[i]),
        _ => format!("{} {} 0 0 0 1 1 0 0 0 //TX1", pts(p), TEXTURES[i]),
    });
    check_box(&mixed, "mixed");
}

#[test]
fn quake3_and_doom3_brushes() {
    // Quake 3 brush primitives.
    let faces: Vec<String> = box_points()
        .iter()
        .enumerate()
        .map(|(i, p)| {
            format!(
                "{} ( ( 0.03125 0 0 ) ( 0 0.03125 0 ) ) {} 0 0 0",
                pts(p),
                TEXTURES[i]
            )
        })
        .collect();
    let q3 = format!(
        "{{\n\"classname\" \"worldspawn\"\n// brush 0\n{{\nbrushDef\n{{\n{}\n}}\n}}\n}}\n",
        faces.join("\n")
    );
    let ents = parse(&q3).unwrap();
    let b = &ents[0].brushes[0];
    assert_eq!(b.line, 4);
    assert!((volume(b) - BOX_VOLUME).abs() < 1e-6);
    assert_outward(b);

    // Doom 3: `( a b c d )` with a*x + b*y + c*z + d = 0 and (a, b, c) out of the brush,
    // a brush key/value pair, a patch to skip.
    let planes = [
        (-DVec3::X, -LO.x),
        (DVec3::X, HI.x),
        (-DVec3::Y, -LO.y),
        (DVec3::Y, HI.y),
        (-DVec3::Z, -LO.z),
        (DVec3::Z, HI.z),
    ];
    let faces: Vec<String> = planes
        .iter()
        .map(|(n, dist)| {
            format!(
                "  ( {} {} {} {} ) ( ( 0.0078125 0 0 ) ( 0 0.0078125 0 ) ) \"textures/base_wall/lfwall13f3\" 0 0 0",
                n.x, n.y, n.z, -dist
            )
        })
        .collect();
    let d3 = format!(
        "Version 2\n// entity 0\n{{\n\"classname\" \"worldspawn\"\n// primitive 0\n{{\n brushDef3\n {{\n  \"brushkey\" \"x\"\n{}\n }}\n}}\n\
         // primitive 1\n{{\n patchDef2\n {{\n  \"textures/common/caulk\"\n  ( 3 3 0 0 0 )\n(\n( ( -64 -64 0 0 0 ) ( -64 0 0 0 0 ) ( -64 64 0 0 0 ) )\n\
         ( ( 0 -64 0 0 0 ) ( 0 0 0 0 0 ) ( 0 64 0 0 0 ) )\n( ( 64 -64 0 0 0 ) ( 64 0 0 0 0 ) ( 64 64 0 0 0 ) )\n)\n }}\n}}\n}}\n",
        faces.join("\n")
    );
    let ents = parse(&d3).unwrap_or_else(|e| panic!("{e}\n{d3}"));
    assert_eq!(ents.len(), 1);
    assert_eq!(ents[0].brushes.len(), 1, "the patch is skipped");
    let b = &ents[0].brushes[0];
    assert_eq!(b.line, 6);
    assert_eq!(b.faces[0].texture, "textures/base_wall/lfwall13f3");
    assert!((volume(b) - BOX_VOLUME).abs() < 1e-6);
    assert_outward(b);
}

#[test]
fn slanted_faces() {
    // A 64-unit cube cut by x + z <= 64: a wedge of half the cube's volume; and the cube cut
    // by three corner planes into a tetrahedron (x + y + z <= 64 from the origin corner).
    let map = "{\n\"classname\" \"worldspawn\"\n\
        {\n\
        ( 0 1 0 ) ( 0 0 1 ) ( 0 0 0 ) a 0 0 0 1 1\n\
        ( 64 0 1 ) ( 64 1 0 ) ( 64 0 0 ) a 0 0 0 1 1\n\
        ( 0 0 1 ) ( 1 0 0 ) ( 0 0 0 ) a 0 0 0 1 1\n\
        ( 1 64 0 ) ( 0 64 1 ) ( 0 64 0 ) a 0 0 0 1 1\n\
        ( 1 0 0 ) ( 0 1 0 ) ( 0 0 0 ) a 0 0 0 1 1\n\
        ( 0 1 64 ) ( 1 0 64 ) ( 0 0 64 ) a 0 0 0 1 1\n\
        ( 64 0 0 ) ( 0 0 64 ) ( 0 64 64 ) slope 0 0 0 1 1\n\
        }\n\
        {\n\
        ( 0 1 0 ) ( 0 0 1 ) ( 0 0 0 ) a 0 0 0 1 1\n\
        ( 0 0 1 ) ( 1 0 0 ) ( 0 0 0 ) a 0 0 0 1 1\n\
        ( 1 0 0 ) ( 0 1 0 ) ( 0 0 0 ) a 0 0 0 1 1\n\
        ( 64 0 0 ) ( 0 0 64 ) ( 0 64 0 ) slope 0 0 0 1 1\n\
        }\n}\n";
    let ents = parse(map).unwrap();
    let [wedge, tet] = &ents[0].brushes[..] else {
        panic!("two brushes")
    };
    assert!(
        (volume(wedge) - 64f64.powi(3) / 2.0).abs() < 1e-6,
        "{}",
        volume(wedge)
    );
    assert_eq!(wedge.polygons.len(), 5, "the +X and +Z faces clip away");
    assert!(
        (volume(tet) - 64f64.powi(3) / 6.0).abs() < 1e-6,
        "{}",
        volume(tet)
    );
    assert_eq!(tet.triangles.len(), 4);
    for b in [wedge, tet] {
        assert_outward(b);
        assert!(closure_problems(b).is_empty(), "{:?}", closure_problems(b));
    }
    assert!(tet.contains(DVec3::splat(10.0), 1.0));
    assert!(!tet.contains(DVec3::splat(30.0), 0.0));
}

#[test]
fn planes_that_nearly_meet() {
    // A square pyramid whose four sides each have their own, slightly different apex, as a
    // vertex-edited brush saved with rounded points does: the sides miss one another near the
    // top by 1e-7 to 1e-5, leaving tiny edges seen by some faces and not others. (Each set made
    // a brush that was not closed before the reader merged a brush's vertices within 1e-5.)
    let apex_sets = [
        [
            "32.0000000660 32.0000000194 63.9999999647",
            "32.0000000849 31.9999999142 63.9999999821",
            "31.9999999356 31.9999999535 64.0000000330",
            "32.0000000465 32.0000000810 64.0000000649",
        ],
        [
            "31.9999993841 32.0000005157 63.9999994058",
            "31.9999992725 31.9999996843 63.9999997919",
            "31.9999999398 32.0000002904 64.0000000103",
            "31.9999994650 32.0000002123 63.9999997922",
        ],
        [
            "32.0000000405 31.9999961621 64.0000028057",
            "31.9999967418 31.9999969210 64.0000097523",
            "32.0000002413 32.0000006385 63.9999958188",
            "31.9999949913 31.9999979116 63.9999951003",
        ],
    ];
    for apexes in apex_sets {
        let map = format!(
            "{{\n\"classname\" \"worldspawn\"\n{{\n\
             ( 64 0 0 ) ( 0 64 0 ) ( 0 0 0 ) base 0 0 0 1 1\n\
             ( {} ) ( 64 0 0 ) ( 0 0 0 ) s 0 0 0 1 1\n\
             ( {} ) ( 64 64 0 ) ( 64 0 0 ) s 0 0 0 1 1\n\
             ( {} ) ( 0 64 0 ) ( 64 64 0 ) s 0 0 0 1 1\n\
             ( {} ) ( 0 0 0 ) ( 0 64 0 ) s 0 0 0 1 1\n\
             }}\n}}\n",
            apexes[0], apexes[1], apexes[2], apexes[3]
        );
        let ents = parse(&map).unwrap();
        let b = &ents[0].brushes[0];
        assert_eq!(b.polygons.len(), 5, "{apexes:?}");
        let expect = 64.0 * 64.0 * 64.0 / 3.0;
        assert!(
            (volume(b) - expect).abs() < 1e-2,
            "{apexes:?}: {}",
            volume(b)
        );
        assert_outward(b);
        let problems = closure_problems(b);
        assert!(problems.is_empty(), "{apexes:?}: {problems:#?}");
    }
}

#[test]
fn entities_keys_and_degenerate_brushes() {
    let map = r#"
// comment line
{
"classname" "worldspawn"
"wad" "c:\quake\id1\gfx.wad\"
"message" "two words"
}
{
"classname"    "func_door"
"origin" "8 -16 24.5"
"angle" "90"
"angle" "-1"
// three faces only: no volume
{
( 0 1 0 ) ( 0 0 1 ) ( 0 0 0 ) a 0 0 0 1 1
( 0 0 1 ) ( 1 0 0 ) ( 0 0 0 ) a 0 0 0 1 1
( 1 0 0 ) ( 0 1 0 ) ( 0 0 0 ) a 0 0 0 1 1
}
// open on +X: unbounded
{
( 0 1 0 ) ( 0 0 1 ) ( 0 0 0 ) a 0 0 0 1 1
( 0 0 1 ) ( 1 0 0 ) ( 0 0 0 ) a 0 0 0 1 1
( 1 64 0 ) ( 0 64 1 ) ( 0 64 0 ) a 0 0 0 1 1
( 1 0 0 ) ( 0 1 0 ) ( 0 0 0 ) a 0 0 0 1 1
( 0 1 64 ) ( 1 0 64 ) ( 0 0 64 ) a 0 0 0 1 1
}
// a repeated face and one with collinear points: still a box
{
( 0 1 0 ) ( 0 0 1 ) ( 0 0 0 ) a 0 0 0 1 1
( 8 0 1 ) ( 8 1 0 ) ( 8 0 0 ) a 0 0 0 1 1
( 8 0 1 ) ( 8 1 0 ) ( 8 0 0 ) b 0 0 0 1 1
( 0 0 1 ) ( 1 0 0 ) ( 0 0 0 ) a 0 0 0 1 1
( 1 8 0 ) ( 0 8 1 ) ( 0 8 0 ) a 0 0 0 1 1
( 0 0 0 ) ( 1 1 1 ) ( 2 2 2 ) a 0 0 0 1 1
( 1 0 0 ) ( 0 1 0 ) ( 0 0 0 ) a 0 0 0 1 1
( 0 1 8 ) ( 1 0 8 ) ( 0 0 8 ) a 0 0 0 1 1
}
}
{
"classname" "info_player_start"
"origin" "1 2"
}
"#;
    let ents: Vec<Entity> = parse(map).unwrap();
    assert_eq!(ents.len(), 3);
    assert_eq!(ents[0].line, 3);
    assert_eq!(ents[0].get("wad"), Some(r"c:\quake\id1\gfx.wad\"));
    assert_eq!(ents[0].get("message"), Some("two words"));
    assert_eq!(ents[0].origin(), None);
    let door = &ents[1];
    assert_eq!(door.classname(), "func_door");
    assert_eq!(door.get("angle"), Some("-1"), "the last of a repeated key");
    assert_eq!(door.origin(), Some(DVec3::new(8.0, -16.0, 24.5)));
    assert_eq!(door.brushes.len(), 3);
    assert_eq!(door.brushes[0].line, 14);
    assert!(door.brushes[0].triangles.is_empty());
    assert!(door.brushes[1].triangles.is_empty());
    let b = &door.brushes[2];
    assert_eq!(b.faces.len(), 8);
    assert_eq!(b.faces[5].normal, DVec3::ZERO);
    assert_eq!(b.polygons.len(), 6);
    assert!((volume(b) - 512.0).abs() < 1e-9);
    assert!(closure_problems(b).is_empty());
    assert_eq!(ents[2].classname(), "info_player_start");
    assert_eq!(ents[2].origin(), None, "two numbers are no origin");
    assert!(parse("").unwrap().is_empty());
}

#[test]
fn syntax_errors_name_their_line() {
    let cases = [
        ("{\n\"classname\" \"worldspawn\"\n{\n( 0 0 0 ) ( 0 0 1 ) ( 0 1 ) a 0 0 0 1 1\n}\n}\n", 4),
        ("{\n\"classname\" \"worldspawn\"\n{\n( 0 1 0 ) ( 0 0 1 ) ( 0 0 0 ) a 0 0 0 1\n}\n}\n", 5),
        ("{\n\"classname\" \"worldspawn\"\n{\n( 0 1 0 ) ( 0 0 1 ) ( 0 0 0 ) {\n}\n}\n", 4),
        ("{\n\"classname\" \"worldspawn\"\n{\n( 0 1 0 ) ( 0 0 1 ) ( 0 0 0 ) a [ 1 0 0 0 ] 0 1 1\n}\n}\n", 4),
        ("{\n\"classname\"\n\"worldspawn\"\n}\n", 2),
        ("{\n\"classname\" \"worldspawn\n}\n", 2),
        ("}\n", 1),
        ("\n{\n\"classname\" \"worldspawn\"\n", 2),
        ("{\n{\n( 0 1 0 ) ( 0 0 1 ) ( 0 0 0 ) a 0 0 0 1 1 1 2 3 4\n}\n}\n", 3),
    ];
    for (text, line) in cases {
        let e = parse(text).expect_err(text);
        assert!(
            e.starts_with(&format!("line {line}:")),
            "{text:?}: got {e:?}, expected line {line}"
        );
    }
}

#[test]
fn quake_units_to_gltf_metres() {
    let p = to_y_up_metres(DVec3::new(100.0, 200.0, 300.0));
    assert!(p.abs_diff_eq(DVec3::new(2.54, 7.62, -5.08), 1e-12), "{p}");
    // A proper rotation: winding (and so outward normals) survives.
    let (a, b, c) = (DVec3::X, DVec3::Y, DVec3::Z);
    let n = (to_y_up_metres(b) - to_y_up_metres(a)).cross(to_y_up_metres(c) - to_y_up_metres(a));
    let m = to_y_up_metres((b - a).cross(c - a));
    assert!(n.normalize().abs_diff_eq(m.normalize(), 1e-12));
}

/// Parses every brush of a real map and checks it is closed and has a positive volume (brushes
/// that enclose nothing are listed, not failed). Returns the problems found.
fn check_real_map(path: &std::path::Path) -> (Vec<Entity>, Vec<String>, Vec<usize>) {
    let text = std::fs::read(path).unwrap();
    let text = String::from_utf8_lossy(&text);
    let ents = parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (mut problems, mut empty) = (Vec::new(), Vec::new());
    for b in ents.iter().flat_map(|e| &e.brushes) {
        if b.triangles.is_empty() {
            empty.push(b.line);
            continue;
        }
        let v = volume(b);
        if v <= 0.0 {
            problems.push(format!("line {}: volume {v}", b.line));
        }
        for p in closure_problems(b) {
            problems.push(format!("line {}: {p}", b.line));
        }
    }
    (ents, problems, empty)
}

/// ericw-tools' testmaps, e.g. extracted from the mirror one file at a time (`git archive`
/// stops at a blob the mirror lacks, testmaps/deprecated/free_wad.wad):
///
/// ```text
/// G="git --git-dir=/work/.mirror/ericwa+ericw-tools/repo"
/// $G ls-tree -r HEAD testmaps | while read -r _ _ sha path; do
///   mkdir -p "/tmp/testmaps/$(dirname "$path")"; $G cat-file blob "$sha" > "/tmp/testmaps/$path"
/// done
/// ERICW_TESTMAPS=/tmp/testmaps/testmaps cargo test --release --test map_reader -- --include-ignored
/// ```
#[test]
#[ignore = "needs ericw-tools' testmaps (ERICW_TESTMAPS or ../shared/levels/ericw-tools)"]
fn ericw_testmaps() {
    let dir = common::ericw_testmaps();

    // E1M1 with its entities edited: counts from the file's brace structure.
    let (ents, problems, empty) = check_real_map(&dir.join("E1M1-edited-ents.map"));
    assert_eq!(ents.len(), 370);
    assert_eq!(ents[0].classname(), "worldspawn");
    assert_eq!(ents[0].brushes.len(), 1163);
    assert_eq!(ents.iter().map(|e| e.brushes.len()).sum::<usize>(), 1257);
    // 7523 face lines, and every face has a polygon: no brush there has a face that clips away.
    let brushes = || ents.iter().flat_map(|e| &e.brushes);
    assert_eq!(brushes().map(|b| b.faces.len()).sum::<usize>(), 7523);
    assert_eq!(brushes().map(|b| b.polygons.len()).sum::<usize>(), 7523);
    assert!(brushes().all(|b| b.faces.iter().all(|f| f.normal != DVec3::ZERO)));
    assert_eq!(
        ents.iter().filter(|e| e.classname() == "light").count(),
        190
    );
    assert_eq!(
        ents.iter()
            .filter(|e| e.classname() == "func_door")
            .map(|e| e.brushes.len())
            .sum::<usize>(),
        35
    );
    assert!(problems.is_empty(), "{problems:#?}");
    assert!(
        empty.is_empty(),
        "brushes with no volume at lines {empty:?}"
    );
    assert!(brushes().all(|b| volume(b) > 0.0));

    // Every map in the folder (recursively): parses, and each brush with a volume is closed.
    let mut maps = Vec::new();
    let mut stack = vec![dir];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x.eq_ignore_ascii_case("map")) {
                maps.push(p);
            }
        }
    }
    maps.sort();
    let (mut all_problems, mut brushes, mut no_volume) = (Vec::new(), 0, 0);
    for m in &maps {
        let (ents, problems, empty) = check_real_map(m);
        brushes += ents.iter().map(|e| e.brushes.len()).sum::<usize>();
        no_volume += empty.len();
        if !empty.is_empty() {
            eprintln!("{}: brushes with no volume at lines {empty:?}", m.display());
        }
        all_problems.extend(
            problems
                .into_iter()
                .map(|p| format!("{}: {p}", m.display())),
        );
    }
    eprintln!(
        "{} maps, {brushes} brushes, {no_volume} with no volume, {} problems",
        maps.len(),
        all_problems.len()
    );
    assert!(all_problems.is_empty(), "{all_problems:#?}");
}
