//! `cargo run --release -p portcullis-bevy --example bench -- LEVEL.glb --cameras FILE`: what
//! the plugin costs per frame and what it saves, in a headless Bevy app. Each camera of FILE is
//! run as frames twice, with the plugin's `PortalCamera` on the camera and without it (Bevy's
//! frustum culling alone); printed: the median frame time of each and their difference (the
//! plugin's cost: the trace and cutting the view's list), and the meshes each keeps in the
//! view per frame.

use std::time::Instant;

use bevy::prelude::Camera3d;
use portcullis_bevy::headless;
use portcullis_bevy::portcullis_runtime::runtime::answer::CameraLine;
use portcullis_bevy::PortalCamera;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (level, cameras) = match args.as_slice() {
        [level, flag, cameras] if flag == "--cameras" => (level, cameras),
        _ => {
            eprintln!("usage: bench LEVEL.glb --cameras FILE");
            std::process::exit(2)
        }
    };
    let fail = |why: String| -> ! {
        eprintln!("error: {why}");
        std::process::exit(2)
    };
    let text = std::fs::read_to_string(cameras).unwrap_or_else(|e| fail(format!("{cameras}: {e}")));
    let mut lines = Vec::new();
    for (i, l) in text.lines().enumerate() {
        match CameraLine::parse(l) {
            Ok(Some(c)) if c.view().is_ok() => lines.push(c),
            Ok(None) => {}
            _ => fail(format!("{cameras}:{}: not a usable camera", i + 1)),
        }
    }
    if lines.is_empty() {
        fail(format!("{cameras}: no cameras"));
    }
    let (mut app, handle, _) =
        headless::app_with_level(level.as_ref()).unwrap_or_else(|e| fail(e.to_string()));
    let camera = app.world_mut().spawn(Camera3d::default()).id();
    let mut report = Vec::new();
    for culled in [false, true] {
        if culled {
            app.world_mut()
                .entity_mut(camera)
                .insert(PortalCamera::new(handle.clone()));
        }
        let (mut times, mut kept) = (Vec::new(), 0usize);
        for round in 0..3 {
            for c in &lines {
                headless::aim(app.world_mut(), camera, c, false).expect("a usable camera");
                let t = Instant::now();
                app.update();
                if round > 0 {
                    times.push(t.elapsed().as_secs_f64() * 1e6);
                    kept += headless::drawn_meshes(app.world(), camera).len();
                }
            }
        }
        let frames = times.len();
        report.push((median(times), kept as f64 / frames as f64));
    }
    let ((plain, plain_kept), (culled, culled_kept)) = (report[0], report[1]);
    println!("{} cameras, 2 rounds each after a warm-up", lines.len());
    println!("frame, frustum culling alone:   median {plain:.1} us, {plain_kept:.1} meshes kept");
    println!("frame, with PortalCamera:       median {culled:.1} us, {culled_kept:.1} meshes kept");
    println!(
        "the plugin's cost per frame:    {:.1} us (difference of medians)",
        culled - plain
    );
}
