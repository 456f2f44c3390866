//! Near misses: names that look like a tag but match no rule.
//!
//! Silent tag failures are the most common complaint against the anchor tools (a room called
//! `Kitchen_Room ` is simply not a room, and nobody says so). A name is a near miss when a
//! small, typical slip (stray whitespace, Blender's `.001` duplicate suffix, the wrong
//! separator, the wrong case) is all that stands between it and a rule; the fix is then that
//! corrected name, which we can show.

use super::rules::{MatchOn, RuleSet};

/// A rule the name almost matched, and the name that would match it.
#[derive(Debug, Clone)]
pub struct Miss {
    pub rule: usize,
    pub suggestion: String,
    pub slip: &'static str,
}

const SEPARATORS: [char; 4] = ['-', '_', '.', ' '];

/// Corrected spellings of `name`, each with the slip it corrects, most specific first.
fn variants(name: &str) -> Vec<(String, &'static str)> {
    let mut out: Vec<(String, &'static str)> = Vec::new();
    let push = |s: String, why: &'static str, out: &mut Vec<(String, &'static str)>| {
        if s != name && !s.is_empty() && !out.iter().any(|(o, _)| *o == s) {
            out.push((s, why));
        }
    };
    let trimmed = name.trim().to_string();
    push(trimmed.clone(), "leading or trailing whitespace", &mut out);
    let unsuffixed = strip_duplicate_suffix(&trimmed);
    push(
        unsuffixed.clone(),
        "a duplicate-name suffix such as `.001`",
        &mut out,
    );
    let suffixed = unsuffixed != trimmed;
    for (base, why) in [
        (
            &unsuffixed,
            if suffixed {
                "a duplicate-name suffix such as `.001` and a different separator"
            } else {
                "a different separator"
            },
        ),
        (&trimmed, "a different separator"),
    ] {
        for sep in ['-', '_'] {
            let swapped: String = base
                .chars()
                .map(|c| if SEPARATORS.contains(&c) { sep } else { c })
                .collect();
            push(swapped, why, &mut out);
        }
    }
    let lowered: Vec<(String, &'static str)> = out
        .iter()
        .map(|(s, _)| s.to_lowercase())
        .chain(std::iter::once(name.to_lowercase()))
        .map(|s| (s, "letter case"))
        .collect();
    for (s, why) in lowered {
        push(s, why, &mut out);
    }
    out
}

/// `Room.001` -> `Room`; `Room.12` stays (only Blender's three-digit form).
fn strip_duplicate_suffix(s: &str) -> String {
    if let Some(dot) = s.rfind('.') {
        let tail = &s[dot + 1..];
        if tail.len() >= 3 && tail.chars().all(|c| c.is_ascii_digit()) {
            return s[..dot].to_string();
        }
    }
    s.to_string()
}

/// The rule `name` narrowly misses, if any. Call only for names no rule accepts.
pub fn check(rules: &RuleSet, name: &str) -> Option<Miss> {
    variants(name).into_iter().find_map(|(v, slip)| {
        rules.match_text(MatchOn::Name, &v).map(|m| Miss {
            rule: m.rule,
            suggestion: v,
            slip,
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tags::presets;

    fn default_rules() -> RuleSet {
        presets::load("default").unwrap()
    }

    #[test]
    fn typical_slips_are_caught_with_a_fix() {
        let r = default_rules();
        let m = check(&r, "Kitchen_Room ").expect("near miss");
        assert_eq!(r.rules[m.rule].spec.id, "godot.room");
        assert_eq!(m.suggestion, "Kitchen-Room");
        let m = check(&r, "Room-kitchen.001").expect("near miss");
        assert_eq!(r.rules[m.rule].spec.id, "lportal.room");
        assert_eq!(m.suggestion, "Room_kitchen");
        let m = check(&r, "lounge portal").expect("near miss");
        assert_eq!(r.rules[m.rule].spec.id, "godot.portal");
    }

    #[test]
    fn ordinary_names_are_not_near_misses() {
        let r = default_rules();
        for n in [
            "Wall_Door_Centre",
            "RoomList",
            "cells",
            "portals",
            "Floor",
            "@Wall@2",
            "Bathroom_tiles",
            "levelgeo",
            "Spotlight",
        ] {
            assert!(check(&r, n).is_none(), "{n} flagged");
        }
    }

    #[test]
    fn duplicate_suffix_only_strips_three_digits() {
        assert_eq!(strip_duplicate_suffix("a.001"), "a");
        assert_eq!(strip_duplicate_suffix("a.5"), "a.5");
    }
}
