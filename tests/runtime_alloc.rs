//! A trace allocates nothing once its buffers have grown (issue 27): a counting allocator
//! around the system one, counting only on this test's thread while the traces run. Its own
//! test binary, since the global allocator is per binary.

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use common::rng::SplitMix64 as Rng;
use portcullis::runtime::{Doors, Level, Trace, TraceOptions, View};

struct Counting;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static COUNT: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc(l) }
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc_zeroed(l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        note();
        unsafe { System.realloc(p, l, n) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) }
    }
}

fn note() {
    let _ = COUNTING.try_with(|on| {
        if on.get() {
            let _ = COUNT.try_with(|c| c.set(c.get() + 1));
        }
    });
}

#[global_allocator]
static ALLOC: Counting = Counting;

fn allocations_during(f: impl FnOnce()) -> usize {
    COUNT.with(|c| c.set(0));
    COUNTING.with(|on| on.set(true));
    f();
    COUNTING.with(|on| on.set(false));
    COUNT.with(|c| c.get())
}

#[test]
fn traces_allocate_nothing_after_warm_up() {
    let dir = tempfile::tempdir().unwrap();
    let mut total_visible = 0;
    for (name, level) in [
        ("two_rooms", common::sample("two_rooms.gltf")),
        ("mirror", common::sample("mirror.gltf")),
        ("teleporter", common::sample("teleporter.gltf")),
        ("courtyard", common::sample("courtyard.gltf")),
        ("MAP01", common::fixture("MAP01_godot.glb")),
    ] {
        let out = dir.path().join(format!("{name}.glb"));
        portcullis::pipeline::convert_file(&level, &out).unwrap();
        let level = Level::load(&out).unwrap();
        let doors = Doors::new(&level);
        let opts = TraceOptions::default();
        // Cameras at the centres of cells, looking along each horizontal axis.
        let mut rng = Rng::new(3);
        let views: Vec<View> = (0..level.cells().min(200))
            .flat_map(|c| {
                let (lo, hi) = level.bounds(c);
                let eye = [
                    (lo[0] + hi[0]) / 2.0,
                    (lo[1] + hi[1]) / 2.0,
                    (lo[2] + hi[2]) / 2.0,
                ];
                let a = rng.unit() * std::f64::consts::TAU;
                [0.0, 1.5, 3.0, 4.5].map(|k: f64| {
                    View::new(
                        eye,
                        [(a + k).cos(), 0.0, (a + k).sin()],
                        [0.0, 1.0, 0.0],
                        75.0,
                        1.7,
                        0.05,
                    )
                    .unwrap()
                })
            })
            .collect();
        let mut trace = Trace::default();
        let mut touching = Vec::new();
        // One frame's work: every trace, and a box at each visible cell's middle placed
        // (`cells_touching`) and culled (`box_visible`), as an engine's moving objects.
        let frame = |trace: &mut Trace, touching: &mut Vec<usize>| {
            let (mut seen, mut boxes) = (0, 0);
            for v in &views {
                level.trace(v, &doors, &opts, trace);
                seen += trace.visible().len();
                for (e, entry) in trace.visible().iter().enumerate() {
                    let Some(c) = entry.cell else { continue };
                    let (lo, hi) = level.bounds(c);
                    let mid = glam::DVec3::from(lo).lerp(glam::DVec3::from(hi), 0.5);
                    let half = glam::DVec3::splat(0.25);
                    level.cells_touching(mid - half, mid + half, touching);
                    boxes += usize::from(trace.box_visible(e, mid - half, mid + half));
                }
            }
            (seen, boxes)
        };
        // Warm-up: the buffers grow to the largest trace.
        frame(&mut trace, &mut touching);
        let mut result = (0, 0);
        let n = allocations_during(|| result = frame(&mut trace, &mut touching));
        let (seen, boxes) = result;
        assert!(boxes > 0, "{name}: no box was ever visible");
        assert_eq!(n, 0, "{name}: {n} allocations in {} traces", views.len());
        total_visible += seen;
    }
    // The counter counts: a fresh vector allocates once.
    let probe = allocations_during(|| {
        let v: Vec<u64> = Vec::with_capacity(4);
        std::hint::black_box(v);
    });
    assert_eq!(probe, 1);
    assert!(total_visible > 100, "{total_visible}");
}
