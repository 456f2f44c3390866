//! Checks of a level's cells and portals as a whole: portal shape and pairing, transforms,
//! the cell graph, loops through transforms and leaks. The stages that build cells and
//! portals report what they see while building; these checks look at the result, so they run
//! the same on a level portcullis just built ([`Subject::built`]) and on the annotation stored
//! in a file it wrote earlier ([`stored::subject`]) — the latter is what an engine will load.
//!
//! Every finding is a [`Diagnostic`] located at the portal's node (or its JSON pointer in a
//! stored annotation) with the 3D point it concerns, so a designer can go there.
//!
//! A [`Subject`] is cells (polyhedra and labels), a `PortalSet`, where each portal is in the file,
//! the tolerance, the level's extent and the player starts. `portals.rs`: at least three distinct
//! points off one line (the same `usable_polygon` test the builder uses), planar, convex, on the
//! source cell's boundary (across a wall up to its thickness), between two cells, partners mutual
//! with the same polygon reversed (compared on one plane, since across a wall the two lie on
//! opposite faces), no two overlapping the same way between the same cells. `transforms.rs`:
//! finite; a teleporter's rigid and proper; a mirror's the reflection in its own plane; a partner's
//! the inverse; a teleporter's exit the image of its entry. `graph.rs`: union-find parts (the part
//! holding the first player start, else the largest, is the level; the others are unreachable) and
//! strongly connected parts from `scc.rs` (a part with a way in but none out is a one-way dead
//! end). Loops come from `portals/loops.rs`. `leaks.rs`: exterior portals; in a sealed level, one
//! LEAK per leaking cell with the shortest cell chain from a player start (BFS; no start: the cell
//! itself) and a polyline from the start through the portal centres to a step outside, which
//! `convert --debug` draws. `sightlines.rs` (`check --sightlines N`, run after the others, and only
//! when asked) audits a PVS against the triangles that block sight (`portals::blocking_triangles`);
//! it shares nothing with `vis` but the cells and portals.
//!
//! The portal checks, the loops and the rest run side by side, their findings joined in that fixed
//! order. Invariant: checks never mutate; the same subject gives the same findings in the same
//! order, whatever the thread count.

use std::path::PathBuf;

use glam::DVec3;
use rayon::prelude::*;

use crate::diag::{Code, Diagnostic, Diagnostics, Location};
use crate::geom::polyhedron::ConvexPolyhedron;
use crate::level::{Level, Tagged};
use crate::portals::PortalSet;

mod graph;
mod leaks;
mod portals;
pub mod sightlines;
pub mod stored;
mod transforms;

/// What the user asked the checks to assume.
#[derive(Debug, Clone, Copy, Default)]
pub struct Options {
    /// The level is meant to be closed: openings to the exterior are leaks (errors).
    pub sealed: bool,
}

/// A cell as the checks need it.
#[derive(Debug, Clone)]
pub struct CellInfo {
    /// None when a stored cell's planes do not close a volume.
    pub poly: Option<ConvexPolyhedron>,
    /// `cell 3 (room `hall`)`.
    pub label: String,
    /// Where the cell comes from: its room's node, or its place in a stored annotation.
    pub at: Location,
}

/// A player start or another occupant: where leak paths begin.
#[derive(Debug, Clone)]
pub struct Start {
    /// World position of the start (m).
    pub point: DVec3,
    /// How reports name the start (its node's name).
    pub label: String,
    /// A player start (not another occupant): leak paths run from one when they can.
    pub player: bool,
    /// Where the start comes from, for diagnostics.
    pub at: Location,
}

/// A level's cells and portals, with what is needed to say where a problem is.
#[derive(Debug, Clone)]
pub struct Subject<'a> {
    /// The level's file, for diagnostics.
    pub file: PathBuf,
    /// Per cell, what the checks need of it (index as in the cell set).
    pub cells: Vec<CellInfo>,
    /// The portals to check.
    pub portals: &'a PortalSet,
    /// Where each portal comes from (its authored node, or its place in a stored annotation);
    /// the checks add the 3D point.
    pub portal_at: Vec<Location>,
    /// `portal 4 (`door_b`)`.
    pub portal_label: Vec<String>,
    /// The distance tolerance (m).
    pub eps: f64,
    /// The level's bounding-box diagonal (m).
    pub extent: f64,
    /// Portals this far across a wall still lie on their cells' boundary (m).
    pub max_wall_thickness: f64,
    /// Gaps narrower than this are closed (m): the sightline audit's rays are this thick.
    pub crack: f64,
    /// Occupants, player starts first: where leak searches begin (none: no leak search).
    pub starts: Vec<Start>,
    /// Where two rooms' cells overlapped before one was cut around the other (the region and
    /// the two rooms' names), for the sightline audit to name; none for a stored annotation.
    pub overlaps: Vec<(crate::geom::polyhedron::ConvexPolyhedron, [String; 2])>,
}

/// What the checks found.
#[derive(Debug, Clone, Default)]
pub struct Findings {
    /// The problems found, in check order.
    pub diagnostics: Diagnostics,
    /// One polyline per leak, from a start through the cells to the exterior, for debug output.
    pub leaks: Vec<Vec<DVec3>>,
}

impl<'a> Subject<'a> {
    /// The subject for a level just built.
    pub fn built(level: &'a Level) -> Subject<'a> {
        let (tagged, cells, portals) = (&level.tagged, &level.cells, &level.portals);
        let scene = &tagged.scene;
        let room = |c: usize| {
            cells
                .cells
                .get(c)
                .and_then(|cell| tagged.tagging.rooms.get(cell.room))
                .map_or("?", |r| r.name.as_str())
        };
        let node_at = |n: crate::scene::NodeId| {
            Location::file(&scene.path)
                .with_source(scene.nodes[n].source.clone())
                .with_node(scene.node_path(n))
        };
        let room_at = |c: usize| match cells
            .cells
            .get(c)
            .and_then(|cell| tagged.tagging.rooms.get(cell.room))
        {
            Some(r) => node_at(r.node),
            None => Location::file(&scene.path),
        };
        let cell_infos = cells
            .cells
            .par_iter()
            .enumerate()
            .map(|(i, c)| CellInfo {
                poly: Some(c.poly.clone()),
                label: format!("cell {i} (room `{}`)", room(i)),
                at: room_at(i),
            })
            .collect();
        // A derived portal has no node of its own: it is located at its source room's.
        let portal_at = portals
            .portals
            .par_iter()
            .map(|p| match p.authored {
                Some(n) => node_at(n),
                None => room_at(p.from),
            })
            .collect();
        let portal_label = portals
            .portals
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                let name = p.authored.map(|n| scene.node_label(n));
                portal_label(i, name.as_deref(), room(p.from), p.to.map(room))
            })
            .collect();
        let bounds = cells
            .cells
            .iter()
            .fold(crate::geom::aabb::Aabb::EMPTY, |b, c| b.union(&c.bounds));
        Subject {
            file: scene.path.clone(),
            cells: cell_infos,
            portals,
            portal_at,
            portal_label,
            eps: cells.tolerance.distance,
            extent: if bounds.is_empty() {
                1.0
            } else {
                bounds.size().length()
            },
            max_wall_thickness: tagged.config.portals.max_wall_thickness,
            crack: cells.crack,
            starts: starts(tagged, &cells.buried),
            overlaps: cells
                .overlaps
                .iter()
                .map(|o| {
                    (
                        o.region.clone(),
                        o.rooms.map(|r| tagged.tagging.rooms[r].name.clone()),
                    )
                })
                .collect(),
        }
    }

    /// The location of portal `i` at point `p`.
    pub(crate) fn at(&self, i: usize, p: DVec3) -> Location {
        self.portal_at
            .get(i)
            .cloned()
            .unwrap_or_else(|| Location::file(&self.file))
            .with_position(p.to_array())
    }

    pub(crate) fn portal(&self, i: usize) -> &str {
        self.portal_label.get(i).map_or("portal ?", String::as_str)
    }

    pub(crate) fn cell(&self, c: usize) -> &str {
        self.cells.get(c).map_or("cell ?", |c| c.label.as_str())
    }

    /// A point inside cell `c`, for locations.
    pub(crate) fn cell_point(&self, c: usize) -> Option<DVec3> {
        self.cells
            .get(c)
            .and_then(|c| c.poly.as_ref())
            .map(ConvexPolyhedron::interior_point)
    }
}

/// `portal 4 `door` (`hall` -> `kitchen`)`, the way every check names a portal.
pub(crate) fn portal_label(i: usize, name: Option<&str>, from: &str, to: Option<&str>) -> String {
    let name = name.map(|n| format!(" `{n}`")).unwrap_or_default();
    let to = to.map_or("the exterior".to_string(), |t| format!("`{t}`"));
    format!("portal {i}{name} (`{from}` -> {to})")
}

/// The occupants of a tagged level (player starts first), at their nodes' origins, but for
/// those `buried` inside a solid block, which seed nothing.
pub fn starts(tagged: &Tagged, buried: &[crate::scene::NodeId]) -> Vec<Start> {
    let scene = &tagged.scene;
    let starts = tagged.tagging.player_starts.len();
    tagged
        .tagging
        .all_occupants()
        .enumerate()
        .filter(|(_, s)| !buried.contains(&s.node))
        .map(|(k, s)| {
            let n = &scene.nodes[s.node];
            let what = if k < starts {
                "player start"
            } else {
                "occupant"
            };
            Start {
                point: scene.place(s.node),
                label: format!("{what} `{}`", scene.node_label(s.node)),
                player: k < starts,
                at: Location::file(&scene.path)
                    .with_source(n.source.clone())
                    .with_node(s.path.clone()),
            }
        })
        .collect()
}

/// Runs every check.
pub fn run(s: &Subject, opts: &Options) -> Findings {
    // The portal checks, the loops and the rest read the subject only: they run side by side
    // and their findings are joined in this order, whatever the thread count.
    let (mut f, (looped, rest)) = rayon::join(
        || {
            let mut f = Findings::default();
            portals::check(s, &mut f.diagnostics);
            f
        },
        || {
            rayon::join(
                || {
                    let mut d = Diagnostics::default();
                    loops(s, &mut d);
                    d
                },
                || {
                    let mut before = Diagnostics::default();
                    transforms::check(s, &mut before);
                    let seeds = seed_cells(s, &mut before);
                    graph::check(s, &seeds, &mut before);
                    let mut leaks = Findings::default();
                    leaks::check(s, &seeds, opts, &mut leaks);
                    (before, leaks)
                },
            )
        },
    );
    let (before, leaks) = rest;
    f.diagnostics.extend(before.0);
    f.diagnostics.extend(looped.0);
    f.diagnostics.extend(leaks.diagnostics.0);
    f.leaks = leaks.leaks;
    f
}

/// Where each player start is: its cell, or a warning that it is in none.
fn seed_cells(s: &Subject, out: &mut Diagnostics) -> Vec<(usize, usize)> {
    let mut seeds = Vec::new();
    for (k, st) in s.starts.iter().enumerate() {
        let inside = s.cells.iter().position(|c| {
            c.poly
                .as_ref()
                .is_some_and(|p| p.contains(st.point, 10.0 * s.eps))
        });
        match inside {
            Some(c) => seeds.push((k, c)),
            None => out.push(
                Diagnostic::new(
                    if st.player {
                        Code::PLAYER_START_OUTSIDE
                    } else {
                        Code::OCCUPANT_OUTSIDE
                    },
                    format!("{} lies in no cell", st.label),
                    st.at.clone().with_position(st.point.to_array()),
                )
                .hint(if st.player {
                    "move it inside a room (above the floor, below the ceiling); leak paths start from every cell instead"
                } else {
                    "move it into a room's air, or tag it `ignore` if it marks nothing; in a sealed level an occupant outside every room is a leak"
                }),
            ),
        }
    }
    seeds
}

fn loops(s: &Subject, out: &mut Diagnostics) {
    for l in crate::portals::loops::find_loops(s.portals, s.extent) {
        let chain: Vec<String> = l.portals.iter().map(|&i| s.portal(i).to_string()).collect();
        let first = l.portals[0];
        let centre = centroid(&s.portals.portals[first].polygon);
        let drift = if l.drift > s.eps {
            format!("; one round moves the image {:.3} m", l.drift)
        } else {
            "; one round maps the level onto itself".to_string()
        };
        out.push(
            Diagnostic::new(
                Code::GRAPH_TRANSFORM_LOOP,
                format!(
                    "sightlines loop without bound through {}, back to the first{drift}",
                    chain.join(" -> ")
                ),
                s.at(first, centre),
            )
            .hint(format!(
                "stop recursing after {} portals through transforms at run time (portcullis vis uses this depth), or turn them so they cannot see each other",
                l.depth
            )),
        );
    }
}

pub(crate) fn centroid(poly: &[DVec3]) -> DVec3 {
    poly.iter().copied().sum::<DVec3>() / poly.len().max(1) as f64
}

/// Directed cell edges of the portal graph: (from, to, portal), closed portals included
/// (a closed door is still a way through once opened).
pub(crate) fn edges(s: &Subject) -> Vec<(usize, usize, usize)> {
    s.portals
        .portals
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            p.to.filter(|&t| t != p.from && t < s.cells.len() && p.from < s.cells.len())
                .map(|t| (p.from, t, i))
        })
        .collect()
}
