//! Convex partition of floor plans: exact piece counts on the shapes levels are made of, and
//! the invariants (convex, non-overlapping, area-preserving) on seeded random polygons.

use glam::DVec2;
use portcullis::geom::partition::{convex_partition, union_triangles, PartitionError, Polygon2};
use robust::{orient2d, Coord};

fn orient(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    orient2d(
        Coord { x: a.x, y: a.y },
        Coord { x: b.x, y: b.y },
        Coord { x: c.x, y: c.y },
    )
}

fn signed_area(r: &[DVec2]) -> f64 {
    (0..r.len())
        .map(|i| r[i].perp_dot(r[(i + 1) % r.len()]))
        .sum::<f64>()
        * 0.5
}

fn pts(r: &[(f64, f64)]) -> Vec<DVec2> {
    r.iter().map(|&(x, y)| DVec2::new(x, y)).collect()
}

fn poly(outer: &[(f64, f64)], holes: &[&[(f64, f64)]]) -> Polygon2 {
    Polygon2 {
        outer: pts(outer),
        holes: holes.iter().map(|h| pts(h)).collect(),
    }
}

/// Even-odd point-in-polygon (the point is never on an edge in these tests).
fn inside(p: &Polygon2, q: DVec2) -> bool {
    let mut odd = false;
    for r in std::iter::once(&p.outer).chain(&p.holes) {
        for i in 0..r.len() {
            let (a, b) = (r[i], r[(i + 1) % r.len()]);
            if (a.y > q.y) != (b.y > q.y) && q.x < a.x + (q.y - a.y) / (b.y - a.y) * (b.x - a.x) {
                odd = !odd;
            }
        }
    }
    odd
}

/// Convex polygons have disjoint interiors iff an edge of one has the other entirely on its
/// outer side (exact, via orient2d).
fn disjoint(p: &[DVec2], q: &[DVec2]) -> bool {
    let separates = |a: &[DVec2], b: &[DVec2]| {
        (0..a.len()).any(|i| {
            let (u, v) = (a[i], a[(i + 1) % a.len()]);
            b.iter().all(|&w| orient(u, v, w) <= 0.0)
        })
    };
    separates(p, q) || separates(q, p)
}

/// Checks every invariant and returns the piece count.
fn check(p: &Polygon2) -> usize {
    let pieces = convex_partition(p).unwrap_or_else(|e| panic!("partition failed: {e}"));
    let area = p.area();
    let sum: f64 = pieces.iter().map(|q| signed_area(q)).sum();
    assert!(
        (sum - area).abs() <= 1e-9 * area.abs(),
        "area {sum} vs {area}"
    );
    let corners: Vec<DVec2> = p
        .outer
        .iter()
        .chain(p.holes.iter().flatten())
        .copied()
        .collect();
    for q in &pieces {
        assert!(q.len() >= 3);
        for k in 0..q.len() {
            let o = orient(q[(k + q.len() - 1) % q.len()], q[k], q[(k + 1) % q.len()]);
            assert!(
                o > 0.0,
                "piece {q:?} is not strictly convex and counter-clockwise"
            );
            assert!(
                corners.contains(&q[k]),
                "piece vertex {:?} is not a polygon vertex",
                q[k]
            );
        }
        let centroid = q.iter().copied().sum::<DVec2>() / q.len() as f64;
        assert!(inside(p, centroid), "piece {q:?} lies outside the polygon");
    }
    for i in 0..pieces.len() {
        for j in i + 1..pieces.len() {
            assert!(
                disjoint(&pieces[i], &pieces[j]),
                "pieces {i} and {j} overlap"
            );
        }
    }
    // The union of the pieces has the polygon's area: no overlap, nothing missing.
    let tris: Vec<[DVec2; 3]> = pieces
        .iter()
        .flat_map(|q| (1..q.len() - 1).map(move |k| [q[0], q[k], q[k + 1]]))
        .collect();
    let extent = corners
        .iter()
        .fold(0.0f64, |m, v| m.max(v.x.abs()).max(v.y.abs()));
    let grid = extent * 1e-9;
    let union: f64 = union_triangles(&tris, grid)
        .iter()
        .map(Polygon2::area)
        .sum();
    // Snapping to the grid moves each vertex by at most half a step.
    let perimeter: f64 = pieces
        .iter()
        .flat_map(|q| (0..q.len()).map(|k| q[k].distance(q[(k + 1) % q.len()])))
        .sum();
    assert!(
        (union - area).abs() <= grid * perimeter,
        "union area {union} vs {area}"
    );
    pieces.len()
}

fn transformed(p: &Polygon2, f: impl Fn(DVec2) -> DVec2) -> Polygon2 {
    Polygon2 {
        outer: p.outer.iter().map(|&v| f(v)).collect(),
        holes: p
            .holes
            .iter()
            .map(|h| h.iter().map(|&v| f(v)).collect())
            .collect(),
    }
}

/// Same count when moved far away or scaled: decisions are exact, not tolerance-based.
fn check_invariant(p: &Polygon2) -> usize {
    let n = check(p);
    assert_eq!(
        check(&transformed(p, |v| v + DVec2::new(1e5, 1e5))),
        n,
        "translated by 1e5"
    );
    assert_eq!(check(&transformed(p, |v| v * 1e-3)), n, "scaled by 1e-3");
    assert_eq!(check(&transformed(p, |v| v * 1e3)), n, "scaled by 1e3");
    n
}

fn l_shape() -> Polygon2 {
    poly(
        &[(0., 0.), (6., 0.), (6., 3.), (3., 3.), (3., 6.), (0., 6.)],
        &[],
    )
}

fn u_shape() -> Polygon2 {
    poly(
        &[
            (0., 0.),
            (9., 0.),
            (9., 6.),
            (6., 6.),
            (6., 3.),
            (3., 3.),
            (3., 6.),
            (0., 6.),
        ],
        &[],
    )
}

fn ring() -> Polygon2 {
    poly(
        &[(0., 0.), (6., 0.), (6., 6.), (0., 6.)],
        &[&[(2.5, 2.5), (2.5, 3.5), (3.5, 3.5), (3.5, 2.5)]],
    )
}

#[test]
fn l_is_two() {
    assert_eq!(check_invariant(&l_shape()), 2);
}

#[test]
fn u_is_three() {
    assert_eq!(check_invariant(&u_shape()), 3);
}

#[test]
fn square_ring_is_four() {
    assert_eq!(check_invariant(&ring()), 4);
    let off_centre = poly(
        &[(0., 0.), (10., 0.), (10., 8.), (0., 8.)],
        &[&[(1., 5.), (1., 7.), (3., 7.), (3., 5.)]],
    );
    assert_eq!(check_invariant(&off_centre), 4);
}

#[test]
fn t_is_two() {
    // The bar's lower edge runs straight through both reflex corners: one cut.
    let t = poly(
        &[
            (2., 0.),
            (3., 0.),
            (3., 2.),
            (5., 2.),
            (5., 3.),
            (0., 3.),
            (0., 2.),
            (2., 2.),
        ],
        &[],
    );
    assert_eq!(check_invariant(&t), 2);
}

#[test]
fn plus_is_three() {
    let plus = poly(
        &[
            (1., 0.),
            (2., 0.),
            (2., 1.),
            (3., 1.),
            (3., 2.),
            (2., 2.),
            (2., 3.),
            (1., 3.),
            (1., 2.),
            (0., 2.),
            (0., 1.),
            (1., 1.),
        ],
        &[],
    );
    assert_eq!(check_invariant(&plus), 3);
    let long_arms = transformed(&plus, |v| DVec2::new(v.x * 3.0 - 1.0, v.y));
    assert_eq!(check_invariant(&long_arms), 3);
}

/// A comb: a back of height 1 with `k` teeth of width 1, gap `gap`, height 2; the first tooth
/// starts at `x0` (0 puts it flush with the back's left end).
fn comb(k: usize, gap: f64, x0: f64, tail: f64) -> Polygon2 {
    let w = x0 + k as f64 * (1.0 + gap) - gap + tail;
    let mut r = vec![(0.0, 0.0), (w, 0.0), (w, 1.0)];
    for i in (0..k).rev() {
        let a = x0 + i as f64 * (1.0 + gap);
        r.extend([(a + 1.0, 1.0), (a + 1.0, 3.0), (a, 3.0), (a, 1.0)]);
    }
    r.push((0.0, 1.0));
    // Drop the repeated and collinear points the builder creates at flush ends.
    r.dedup();
    if r.first() == r.last() {
        r.pop();
    }
    poly(&r, &[])
}

#[test]
fn combs_are_teeth_plus_one() {
    for k in 1..=8 {
        for &(gap, x0, tail) in &[
            (1.0, 0.0, 0.0),
            (1.0, 1.0, 1.0),
            (0.5, 0.0, 2.0),
            (2.0, 1.5, 0.0),
        ] {
            let p = comb(k, gap, x0, tail);
            // A single tooth flush with both ends is just a rectangle.
            let expected = if k == 1 && x0 == 0.0 && tail == 0.0 {
                1
            } else {
                k + 1
            };
            assert_eq!(
                check_invariant(&p),
                expected,
                "comb k={k} gap={gap} x0={x0} tail={tail}"
            );
        }
    }
}

#[test]
fn double_comb_is_optimal() {
    // Teeth on both sides of the back, aligned: each tooth still costs one piece.
    let mut r = vec![(0.0, 0.0)];
    for i in 0..4 {
        let a = 1.0 + 2.0 * i as f64;
        r.extend([(a, 0.0), (a, -2.0), (a + 1.0, -2.0), (a + 1.0, 0.0)]);
    }
    r.extend([(10.0, 0.0), (10.0, 1.0)]);
    for i in (0..4).rev() {
        let a = 1.0 + 2.0 * i as f64;
        r.extend([(a + 1.0, 1.0), (a + 1.0, 3.0), (a, 3.0), (a, 1.0)]);
    }
    r.push((0.0, 1.0));
    assert_eq!(check_invariant(&poly(&r, &[])), 9);
}

/// xorshift64*: deterministic, no dependency.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// An x-monotone rectilinear "skyline" with a floor and ceiling profile.
fn skyline(rng: &mut Rng, n: usize) -> Polygon2 {
    let lo: Vec<f64> = (0..n).map(|_| rng.below(4) as f64).collect();
    let hi: Vec<f64> = (0..n).map(|_| 6.0 + rng.below(5) as f64).collect();
    let mut r = Vec::new();
    for (i, &y) in lo.iter().enumerate() {
        r.extend([(i as f64, y), (i as f64 + 1.0, y)]);
    }
    for (i, &y) in hi.iter().enumerate().rev() {
        r.extend([(i as f64 + 1.0, y), (i as f64, y)]);
    }
    let mut outer = pts(&r);
    outer.dedup();
    // Optional rectangular holes in the band every column covers (4 < y < 6).
    let mut holes = Vec::new();
    let mut x = 0.5;
    while x + 1.0 < n as f64 {
        if rng.below(3) == 0 {
            holes.push(pts(&[(x, 4.5), (x, 5.5), (x + 0.5, 5.5), (x + 0.5, 4.5)]));
        }
        x += 2.0;
    }
    Polygon2 { outer, holes }
}

#[test]
fn random_rectilinear_keep_invariants() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    for n in [2usize, 3, 5, 8, 13, 21, 40] {
        for _ in 0..6 {
            let p = skyline(&mut rng, n);
            // Moving by 1e5 and scaling by 1e3 are exact on these coordinates, so every predicate
            // and therefore the whole result repeats. Scaling by 1e-3 rounds the coordinates and
            // may tip a cocircular Delaunay choice, which can change a near-minimal count on
            // large random plans; it must still give a valid partition.
            let count = check(&p);
            assert_eq!(
                check(&transformed(&p, |v| v + DVec2::new(1e5, 1e5))),
                count,
                "translated by 1e5"
            );
            assert_eq!(check(&transformed(&p, |v| v * 1e3)), count, "scaled by 1e3");
            check(&transformed(&p, |v| v * 1e-3));
            // Every piece is at least a unit of the plan's resolution; the bound is loose on purpose.
            assert!(
                count <= 4 * (n + p.holes.len()) + 1,
                "too many pieces: {count} for n={n}"
            );
        }
    }
}

#[test]
fn random_grid_unions_keep_invariants() {
    // Unions of random grid cells: rectilinear plans with holes and corners touching corners.
    let mut rng = Rng(12345);
    for size in [3usize, 5, 8] {
        for _ in 0..8 {
            let mut tris = Vec::new();
            for i in 0..size {
                for j in 0..size {
                    if rng.below(10) < 6 {
                        let (x, y) = (i as f64, j as f64);
                        let [a, b, c, d] = [
                            DVec2::new(x, y),
                            DVec2::new(x + 1.0, y),
                            DVec2::new(x + 1.0, y + 1.0),
                            DVec2::new(x, y + 1.0),
                        ];
                        tris.push([a, b, c]);
                        tris.push([a, c, d]);
                    }
                }
            }
            for p in union_triangles(&tris, 1e-3) {
                check(&p);
            }
        }
    }
}

/// A star-shaped polygon (simple by construction) with an optional star-shaped hole.
fn star(rng: &mut Rng, n: usize, hole: bool) -> Polygon2 {
    // Stratified angles keep every gap under a quarter turn, so the outer ring (radius >= 3)
    // stays clear of the hole (radius <= 1.5) and the polygon is valid by construction.
    let n = if hole { n.max(8) } else { n };
    let mut angles: Vec<f64> = (0..n)
        .map(|k| (k as f64 + rng.unit()) / n as f64 * std::f64::consts::TAU)
        .collect();
    angles.dedup();
    let outer: Vec<DVec2> = angles
        .iter()
        .map(|&t| DVec2::from_angle(t) * (3.0 + 7.0 * rng.unit()))
        .collect();
    let holes = if hole {
        let m = 3 + rng.below(6) as usize;
        let mut r: Vec<DVec2> = (0..m)
            .map(|k| {
                DVec2::from_angle(-(k as f64 + 0.5 * rng.unit()) * std::f64::consts::TAU / m as f64)
                    * (0.5 + rng.unit())
            })
            .collect();
        r.dedup();
        vec![r]
    } else {
        Vec::new()
    };
    Polygon2 { outer, holes }
}

#[test]
fn random_simple_polygons_keep_invariants() {
    let mut rng = Rng(0xDEAD_BEEF_CAFE_F00D);
    for n in [3usize, 4, 6, 10, 20, 50, 120] {
        for k in 0..8 {
            check(&star(&mut rng, n, k % 2 == 1));
        }
    }
}

#[test]
fn a_few_thousand_vertices_are_fast() {
    let mut rng = Rng(7);
    let start = std::time::Instant::now();
    let p = star(&mut rng, 3000, true);
    let pieces = convex_partition(&p).unwrap();
    let sum: f64 = pieces.iter().map(|q| signed_area(q)).sum();
    assert!((sum - p.area()).abs() <= 1e-9 * p.area());
    let comb = comb(500, 1.0, 1.0, 1.0);
    assert_eq!(convex_partition(&comb).unwrap().len(), 501);
    let rect = skyline(&mut rng, 1000);
    convex_partition(&rect).unwrap();
    assert!(
        start.elapsed().as_secs_f64() < 20.0,
        "took {:?}",
        start.elapsed()
    );
}

#[test]
fn bad_input_is_an_error() {
    let nan = poly(&[(0., 0.), (f64::NAN, 0.), (1., 1.)], &[]);
    assert_eq!(convex_partition(&nan), Err(PartitionError::Degenerate));
    let inf = poly(&[(0., 0.), (1., f64::NEG_INFINITY), (1., 1.)], &[]);
    assert_eq!(convex_partition(&inf), Err(PartitionError::Degenerate));
    let flat = poly(&[(0., 0.), (1., 1.), (2., 2.), (1., 1.)], &[]);
    assert_eq!(convex_partition(&flat), Err(PartitionError::Degenerate));
    assert_eq!(
        convex_partition(&poly(&[], &[])),
        Err(PartitionError::Degenerate)
    );
}

#[test]
fn self_overlapping_rings_do_not_panic() {
    // A figure eight, a hole poking out of the outer ring, and a hole crossing another hole.
    let eight = poly(
        &[(0., 0.), (2., 2.), (4., 0.), (4., 2.), (2., 0.), (0., 2.)],
        &[],
    );
    let poking = poly(
        &[(0., 0.), (4., 0.), (4., 4.), (0., 4.)],
        &[&[(3., 1.), (3., 3.), (5., 3.), (5., 1.)]],
    );
    let crossing = poly(
        &[(0., 0.), (10., 0.), (10., 10.), (0., 10.)],
        &[
            &[(2., 2.), (2., 6.), (6., 6.), (6., 2.)],
            &[(4., 4.), (4., 8.), (8., 8.), (8., 4.)],
        ],
    );
    for p in [eight, poking, crossing] {
        if let Ok(pieces) = convex_partition(&p) {
            for q in &pieces {
                for k in 0..q.len() {
                    assert!(
                        orient(q[(k + q.len() - 1) % q.len()], q[k], q[(k + 1) % q.len()]) > 0.0
                    );
                }
            }
        }
    }
    let poking = poly(
        &[(0., 0.), (4., 0.), (4., 4.), (0., 4.)],
        &[&[(3., 1.), (3., 3.), (5., 3.), (5., 1.)]],
    );
    let sum: f64 = convex_partition(&poking)
        .unwrap()
        .iter()
        .map(|q| signed_area(q))
        .sum();
    // Even-odd: the part of the hole inside the square is removed, the part outside is added.
    assert!((sum - (16.0 - 2.0 + 2.0)).abs() < 1e-9, "area {sum}");
}

#[test]
fn union_of_triangulated_ring_has_one_hole() {
    // The square ring of `ring()`, as 8 triangles between the outer and inner squares, mixed windings.
    let o = pts(&[(0., 0.), (6., 0.), (6., 6.), (0., 6.)]);
    let h = pts(&[(2.5, 2.5), (3.5, 2.5), (3.5, 3.5), (2.5, 3.5)]);
    let mut tris = Vec::new();
    for i in 0..4 {
        let j = (i + 1) % 4;
        tris.push([o[i], o[j], h[j]]);
        tris.push([o[i], h[i], h[j]]); // clockwise
    }
    let u = union_triangles(&tris, 1e-4);
    assert_eq!(u.len(), 1);
    assert_eq!(u[0].holes.len(), 1);
    assert_eq!(u[0].outer.len(), 4);
    assert_eq!(u[0].holes[0].len(), 4);
    assert!(signed_area(&u[0].outer) > 0.0 && signed_area(&u[0].holes[0]) < 0.0);
    assert!((u[0].area() - 35.0).abs() < 1e-9, "area {}", u[0].area());
    // Repeatable: the same input gives the same output, bit for bit.
    assert_eq!(union_triangles(&tris, 1e-4), u);
    // And the ring partitions into the optimal four pieces.
    assert_eq!(check(&u[0]), 4);
}

#[test]
fn union_snaps_to_an_absolute_grid() {
    let t = [[
        DVec2::new(0.00004, 0.0),
        DVec2::new(1.0, 0.0),
        DVec2::new(1.0, 1.00004),
    ]];
    let u = union_triangles(&t, 1e-4);
    assert_eq!(u.len(), 1);
    assert!(u[0].outer.contains(&DVec2::new(0.0, 0.0)));
    assert!(u[0].outer.contains(&DVec2::new(1.0, 1.0)));
}

#[test]
fn random_garbage_never_panics() {
    // Random rings that cross themselves and each other, with repeated and collinear points.
    let mut rng = Rng(99);
    for _ in 0..300 {
        let ring = |rng: &mut Rng, n: u64| -> Vec<DVec2> {
            (0..3 + rng.below(n))
                .map(|_| DVec2::new(rng.below(6) as f64, rng.below(6) as f64))
                .collect()
        };
        let outer = ring(&mut rng, 8);
        let holes = (0..rng.below(3)).map(|_| ring(&mut rng, 5)).collect();
        let p = Polygon2 { outer, holes };
        if let Ok(pieces) = convex_partition(&p) {
            for q in &pieces {
                for k in 0..q.len() {
                    assert!(
                        orient(q[(k + q.len() - 1) % q.len()], q[k], q[(k + 1) % q.len()]) > 0.0
                    );
                }
            }
        }
    }
}
