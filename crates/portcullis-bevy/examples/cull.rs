//! `cargo run --release -p portcullis-bevy --example cull -- cull LEVEL.glb --cameras FILE
//! [--closed P]... [--open P]... [--draw-lists] [--format jsonl]`: prints, per camera, the line
//! `portcullis cull LEVEL --cameras FILE --format jsonl` prints, computed inside a headless Bevy
//! app: the level loaded by Bevy's asset server and glTF loader with the plugin, each camera
//! set on a `Camera3d` entity and one frame run per camera, the answer read off the camera's
//! `PortalCamera` after the frame.
//!
//! Cameras are traced in `f64` (`PortalCamera::exact`) so the answers are `cull`'s to the last
//! bit; the `Transform` is set too (in `f32`), as a game's would be.

use std::io::Write;
use std::path::PathBuf;

use bevy::asset::Assets;
use portcullis_bevy::headless;
use portcullis_bevy::portcullis_runtime::runtime::answer::{answer, CameraLine};
use portcullis_bevy::portcullis_runtime::runtime::DrawList;
use portcullis_bevy::{PortalCamera, PortalLevel};

struct Args {
    level: PathBuf,
    cameras: PathBuf,
    closed: Vec<usize>,
    open: Vec<usize>,
    draw_lists: bool,
}

fn fail(why: &str) -> ! {
    eprintln!("error: {why}");
    std::process::exit(2)
}

fn usage(why: &str) -> ! {
    fail(&format!(
        "{why}\nusage: cull LEVEL.glb --cameras FILE [--closed P]... [--open P]... [--draw-lists] [--format jsonl]"
    ))
}

fn args() -> Args {
    let mut it = std::env::args().skip(1);
    if it.next().as_deref() != Some("cull") {
        usage("the first argument is the command, `cull`");
    }
    let (mut level, mut cameras) = (None, None);
    let (mut closed, mut open, mut draw_lists) = (Vec::new(), Vec::new(), false);
    while let Some(a) = it.next() {
        let mut value = |what: &str| {
            it.next()
                .unwrap_or_else(|| usage(&format!("{what} needs a value")))
        };
        let portal = |v: String| {
            v.parse::<usize>()
                .unwrap_or_else(|_| usage(&format!("not a portal id: {v}")))
        };
        match a.as_str() {
            "--cameras" => cameras = Some(PathBuf::from(value("--cameras"))),
            "--closed" => closed.push(portal(value("--closed"))),
            "--open" => open.push(portal(value("--open"))),
            "--draw-lists" => draw_lists = true,
            "--format" => {
                let f = value("--format");
                if f != "jsonl" {
                    usage(&format!("only --format jsonl is printed, not {f}"));
                }
            }
            _ if a.starts_with("--") => usage(&format!("unknown option {a}")),
            _ if level.is_none() => level = Some(PathBuf::from(a)),
            _ => usage(&format!("unexpected argument {a}")),
        }
    }
    Args {
        level: level.unwrap_or_else(|| usage("no level given")),
        cameras: cameras.unwrap_or_else(|| usage("no --cameras FILE given")),
        closed,
        open,
        draw_lists,
    }
}

fn main() {
    let a = args();
    let (mut app, level, _scene) =
        headless::app_with_level(&a.level).unwrap_or_else(|e| fail(&e.to_string()));
    let camera = headless::spawn_camera(app.world_mut(), level.clone());
    {
        let mut levels = app.world_mut().resource_mut::<Assets<PortalLevel>>();
        let mut l = levels.get_mut(&level).expect("the level is loaded");
        let l = &mut *l;
        let n = l.level.portals();
        if let Some(p) = a.closed.iter().chain(&a.open).find(|&&p| p >= n) {
            fail(&format!(
                "[CULL_PORTAL_UNKNOWN] portal {p} does not exist: the level has {n} portals"
            ));
        }
        // rule 17: each door named once (a portal and its partner are one door)
        let mut doors: Vec<usize> = (a.closed.iter().chain(&a.open))
            .map(|&p| l.level.partner(p).map_or(p, |q| q.min(p)))
            .collect();
        doors.sort_unstable();
        if let Some(w) = doors.windows(2).find(|w| w[0] == w[1]) {
            fail(&format!(
                "door {} is given twice (a portal twice, or a portal and its partner); give it once",
                w[0]
            ));
        }
        for (ps, closed) in [(&a.closed, true), (&a.open, false)] {
            for &p in ps {
                l.doors.set(&l.level, p, closed);
            }
        }
    }
    let text = std::fs::read_to_string(&a.cameras)
        .unwrap_or_else(|e| fail(&format!("cannot read {}: {e}", a.cameras.display())));
    // As `cull` does with a file: every line checked before any answer is printed.
    for (i, line) in text.lines().enumerate() {
        let at = format!("{}:{}", a.cameras.display(), i + 1);
        match CameraLine::parse(line) {
            Ok(Some(c)) => {
                if let Err(e) = c.view() {
                    fail(&format!("{at}: not a usable camera: {e}"));
                }
            }
            Ok(None) => {}
            Err(e) => fail(&format!("{at}: not a camera: {e}")),
        }
    }
    let mut out = std::io::stdout().lock();
    let mut list = DrawList::default();
    for (i, line) in text.lines().enumerate() {
        let at = format!("{}:{}", a.cameras.display(), i + 1);
        let c = match CameraLine::parse(line) {
            Ok(Some(c)) => c,
            Ok(None) => continue,
            Err(e) => fail(&format!("{at}: not a camera: {e}")),
        };
        if let Err(e) = headless::aim(app.world_mut(), camera, &c, true) {
            fail(&format!("{at}: not a usable camera: {e}"));
        }
        app.update();
        let world = app.world();
        let l = &world
            .resource::<Assets<PortalLevel>>()
            .get(&level)
            .expect("loaded")
            .level;
        let cam = world.get::<PortalCamera>(camera).expect("the camera");
        if !cam.culled {
            fail("the plugin did not cull the frame");
        }
        let r = answer(&cam.trace, a.draw_lists.then_some((l, &mut list)));
        writeln!(out, "{r}").unwrap_or_else(|_| std::process::exit(0));
    }
}
