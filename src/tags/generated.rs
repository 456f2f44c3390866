//! What `--tags auto` generated (`crate::auto` fills it): the rooms' cells and the settings
//! they were found with. It lives with the tagging, so the cells and portal stages read it
//! without knowing how rooms are found.

use serde::Serialize;

use crate::geom::aabb::Aabb;
use crate::geom::polyhedron::ConvexPolyhedron;
use crate::scene::NodeId;

/// What the generator found, and with which settings, for the output and `inspect`.
#[derive(Debug, Clone, Serialize)]
pub struct Generated {
    /// Edge of a voxel (m).
    pub voxel: f64,
    /// The split ratio used.
    pub split_ratio: f64,
    /// Planes of less area than this (m²) did not cut the cells (`[auto] detail_area`).
    pub detail_area: f64,
    /// Voxels along the frame's axes.
    pub grid: [usize; 3],
    /// The frame's axes (world).
    pub axes: [[f64; 3]; 3],
    /// Voxels a surface touches, and air voxels.
    pub surface_voxels: usize,
    /// Voxels of air.
    pub air_voxels: usize,
    /// The first generated room's index in the tagging; the rest follow.
    pub first_room: usize,
    /// Each generated room's voxel boxes (world): where the room is. The cells stage reads the
    /// level's cells exactly and gives each to the room whose boxes it overlaps most.
    #[serde(skip)]
    pub boxes: Vec<Vec<ConvexPolyhedron>>,
    /// Seconds per step: (step, seconds); for `bench`, never written (a run's output does not
    /// depend on the machine).
    #[serde(skip)]
    pub seconds: Vec<(&'static str, f64)>,
    /// Every blocking node the generator read, by node, with the box of its triangles.
    #[serde(skip)]
    pub(crate) nodes: Vec<(NodeId, Aabb)>,
}

impl Generated {
    /// The voxel boxes of tagging room `room` if the generator made it.
    pub fn boxes_of(&self, room: usize) -> Option<&[ConvexPolyhedron]> {
        let k = room.checked_sub(self.first_room)?;
        self.boxes.get(k).map(|c| c.as_slice())
    }

    /// The box of a blocking node's triangles, if the generator read it.
    pub fn node_bounds(&self, node: NodeId) -> Option<Aabb> {
        let k = self.nodes.binary_search_by_key(&node, |(n, _)| *n).ok()?;
        Some(self.nodes[k].1)
    }
}
