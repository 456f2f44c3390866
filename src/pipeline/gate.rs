//! `check` on one file: a file portcullis annotated is judged by what it stores (its
//! annotation validated, compared with the level for staleness, then checked and audited as
//! stored); any other file, or any with `--recompute`, is built and checked fresh.

use crate::diag::Diagnostics;
use crate::level::Tagged;

/// What checking one file found.
#[derive(Debug, Default)]
pub struct Checked {
    /// Every diagnostic, in stage order (the user's severity policy not yet applied).
    pub diagnostics: Diagnostics,
    /// Whether the file's stored annotation was judged (rather than a fresh build).
    pub annotated: bool,
    /// The cells and portals judged, when there were any to count.
    pub counts: Option<(usize, usize)>,
    /// One polyline per leak, in the level's frame.
    pub leaks: Vec<Vec<glam::DVec3>>,
}

/// How [`check_file`] judges.
#[derive(Debug, Clone, Copy, Default)]
pub struct GateOptions {
    /// Openings to the exterior are errors (added to `[check] sealed`).
    pub sealed: bool,
    /// Rays per cell of the sightline audit (0: none).
    pub rays: usize,
    /// Build and check fresh even when the file stores an annotation.
    pub recompute: bool,
}

/// Checks one tagged file.
pub fn check_file(mut t: Tagged, opts: &GateOptions, input: &std::path::Path) -> Checked {
    let stored = if opts.recompute {
        None
    } else {
        crate::check::stored::read(&t, true)
    };
    let Some(stored) = stored else {
        let mut level = super::build(t);
        let leaks = super::check(&mut level, opts.sealed);
        if opts.rays > 0 {
            let (pvs, note) = super::pvs_noted(&level, crate::vis::Method::Full, input);
            level.diagnostics.extend(note);
            let audit = super::audit(&level, &pvs, opts.rays);
            level.diagnostics.extend(audit.diagnostics);
        }
        level.diagnostics.in_file_units(level.tagged.scene.to_file);
        return Checked {
            counts: Some((level.cells.cells.len(), level.portals.portals.len())),
            diagnostics: level.diagnostics,
            annotated: false,
            leaks,
        };
    };
    let mut checked = Checked {
        annotated: true,
        ..Default::default()
    };
    t.diagnostics.extend(stored.diagnostics.iter().cloned());
    if let (true, Some(ann)) = (stored.sound, &stored.annotated) {
        checked.counts = Some((ann.cells.len(), ann.portals.len()));
        let set = crate::check::stored::portal_set(ann);
        let subject = crate::check::stored::subject(&t, ann, &set);
        let check = crate::check::Options {
            sealed: opts.sealed || t.config.check.sealed,
        };
        let found = crate::check::run(&subject, &check);
        t.diagnostics.extend(found.diagnostics);
        checked.leaks = found.leaks;
        if opts.rays > 0 {
            let audit = super::audit_stored(&t, ann, &subject, opts.rays);
            t.diagnostics.extend(audit.diagnostics);
        }
    }
    t.diagnostics.in_file_units(t.scene.to_file);
    checked.diagnostics = t.diagnostics;
    checked
}
