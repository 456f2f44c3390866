//! Which built-in preset a level follows, when it is not the active one: a Doom conversion run
//! with the default rules tags nothing, and the designer should hear `--tags doom`, not only
//! that no room was found.

use crate::diag::{Code, Diagnostic, Diagnostics, Location};
use crate::scene::{NodeId, Scene};

use super::presets;
use super::rules::RuleSet;

/// A warning naming the preset that tags most of the level's nodes, when that is more than
/// half of them and more than the active rules tag. `tagged` is what the active rules tagged.
/// The caller asks only when the active rules found no room.
pub(super) fn suggest_preset(
    scene: &Scene,
    rules: &RuleSet,
    nodes: &[NodeId],
    tagged: usize,
) -> Option<Diagnostic> {
    let total = nodes.len();
    if total == 0 || 2 * tagged > total {
        return None;
    }
    let count = |r: &RuleSet| {
        use rayon::prelude::*;
        nodes
            .par_iter()
            .filter(|&&n| super::classify(scene, r, n, &mut Diagnostics::default()).is_some())
            .count()
    };
    // A tie goes to the earlier preset, the default last: a level that one specific preset
    // tags as fully as the default follows that preset (Panda3D's `cellN` are footprints).
    let mut names: Vec<&str> = presets::names().collect();
    names.sort_by_key(|p| *p == "default");
    let (name, best) = names
        .into_iter()
        .filter(|p| !p.eq_ignore_ascii_case(&rules.name))
        .filter_map(|p| Some((p, count(&presets::load(p)?))))
        .fold(None::<(&str, usize)>, |acc, (p, c)| match acc {
            Some((_, b)) if b >= c => acc,
            _ => Some((p, c)),
        })?;
    if 2 * best <= total || best <= tagged {
        return None;
    }
    Some(
        Diagnostic::new(
            Code::TAGS_PRESET_SUGGESTED,
            format!(
                "{best} of {total} nodes follow the `{name}` preset's conventions, but the `{}` tag rules are active and tag {tagged}",
                rules.name
            ),
            Location::file(&scene.path),
        )
        .hint(format!(
            "run with --tags {name}, or set `preset = \"{name}\"` under [tags] in portcullis.toml"
        )),
    )
}
