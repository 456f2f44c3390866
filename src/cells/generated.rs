//! The cells of the rooms `--tags auto` generated.
//!
//! The voxel rooms say where rooms are, not what their cells are: a voxel box stops short of
//! a slanted wall, and a ray slipping through that gap reaches a cell no portal leads to. So
//! the untagged level is read once as one room, the way a tagged room is (props set aside, then
//! its prism or its 3D interior: cells bounded by the level's own planes, meeting every wall),
//! and each cell goes to the generated room whose voxel boxes it overlaps most by volume. A
//! cell overlapping none (air the voxels missed: a pocket smaller than the smallest room, a
//! gap under two voxels) goes to the room of the box nearest it, so no air is lost.

use glam::DVec3;

use crate::geom::grid::BoxGrid;
use crate::geom::polyhedron::ConvexPolyhedron;
use crate::scene::NodeId;
use crate::tags::{Room, RoomId, Tagging};

use super::rooms::{GeneratedCells, RoomBuilder};

/// Reads every generated room's structure as one room and shares its cells out (`None` when
/// nothing was generated). `tagged` are the tagged rooms' cells (recentred) with their rooms:
/// tags win. The reading leaves the tagged rooms' geometry out and sees each tagged cell as
/// a closed block instead, its faces surfaces facing out of it, so the generated cells end on
/// them, face to face, and the portal stage joins the two where nothing opaque lies between.
/// (Cut round the tagged cells afterwards, generated cells left slivers the portals did not
/// join: samples/arch.gltf.) Limit: where a tagged room's own wall is thick and modelled as
/// surfaces (a door reveal through it), the wall's inside reads as air next to the block.
pub(super) fn build(
    b: &RoomBuilder,
    tagging: &Tagging,
    tagged: &[(ConvexPolyhedron, RoomId)],
) -> Option<GeneratedCells> {
    let g = tagging.generated.as_deref()?;
    let rooms = &tagging.rooms[g.first_room.min(tagging.rooms.len())..];
    let first = rooms.first()?;
    let mut structure: Vec<NodeId> = rooms
        .iter()
        .flat_map(|r| r.structure.iter().copied())
        .collect();
    structure.sort_unstable();
    structure.dedup();
    let whole = Room {
        structure,
        ..first.clone()
    };
    let (mut polys, mut gates, mut props, mut diags) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let open = tagged_faces(tagged);
    b.structure_polys_with(
        g.first_room,
        &whole,
        &open,
        (&mut polys, &mut gates, &mut props, &mut diags),
    );
    let boxes: Vec<(usize, ConvexPolyhedron)> = (g.boxes.iter().enumerate())
        .flat_map(|(k, bs)| bs.iter().map(move |p| (k, p.translated(-b.origin))))
        .collect();
    let index = BoxGrid::new(boxes.iter().map(|(_, p)| p.bounds()).collect());
    let mut per_room = vec![Vec::new(); rooms.len()];
    for (poly, source) in polys {
        // A cell thinner than a crack is a closed crack (a wafer under a roof): it makes no
        // cell, as in the solid reading. An eye there saw out along the wafer through faces
        // the portal stage closes as cracks.
        if thinner_than(&poly, b.crack) {
            continue;
        }
        let k = room_of(&poly, &boxes, &index, b.eps).min(rooms.len() - 1);
        per_room[k].push((poly, source));
    }
    Some(GeneratedCells {
        first_room: g.first_room,
        per_room,
        props,
        diags,
    })
}

/// The tagged cells' faces, fanned into triangles facing out of the cells.
fn tagged_faces(tagged: &[(ConvexPolyhedron, RoomId)]) -> Vec<[DVec3; 3]> {
    (tagged.iter().flat_map(|(c, _)| &c.faces))
        .flat_map(|f| {
            let p = &f.points;
            (1..p.len().saturating_sub(1)).map(move |i| [p[0], p[i], p[i + 1]])
        })
        .collect()
}

/// Whether the cell is thinner than `width` across one of its faces (the distance from the
/// face's plane to the furthest corner behind it).
fn thinner_than(cell: &ConvexPolyhedron, width: f64) -> bool {
    cell.faces.iter().any(|f| {
        let deepest = (cell.faces.iter().flat_map(|g| g.points.iter()))
            .map(|p| -f.plane.distance(*p))
            .fold(0.0, f64::max);
        deepest < width
    })
}

/// The generated room whose boxes `cell` overlaps most by volume (ties to the lower room),
/// else the room of the box nearest its interior.
fn room_of(
    cell: &ConvexPolyhedron,
    boxes: &[(usize, ConvexPolyhedron)],
    index: &BoxGrid,
    eps: f64,
) -> usize {
    let mut shares: Vec<(usize, f64)> = Vec::new();
    for i in index.query(&cell.bounds(), 0.0) {
        let (k, p) = &boxes[i];
        let v = cell.intersection(p, eps).map_or(0.0, |x| x.volume());
        if v > 0.0 {
            match shares.iter_mut().find(|(r, _)| r == k) {
                Some(s) => s.1 += v,
                None => shares.push((*k, v)),
            }
        }
    }
    if let Some((k, _)) = shares
        .iter()
        .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
    {
        return *k;
    }
    let at = cell.interior_point();
    boxes
        .iter()
        .map(|(k, p)| (p.bounds().distance_to(at), *k))
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        .map_or(0, |(_, k)| k)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::aabb::Aabb;

    /// A slab 0.7 mm thick is thinner than an 8 mm crack however long and wide; a 2.5 cm
    /// sliver is not.
    #[test]
    fn a_wafer_is_thinner_than_a_crack_and_a_sliver_is_not() {
        let slab = |t: f64| {
            ConvexPolyhedron::from_aabb(&Aabb {
                min: DVec3::ZERO,
                max: DVec3::new(53.0, 0.02, t),
            })
        };
        assert!(thinner_than(&slab(0.0007), 0.008));
        assert!(!thinner_than(&slab(0.025), 0.008));
        assert!(!thinner_than(&slab(0.0007), 0.0));
    }
}
