//! Near misses: names that look like a tag but match no rule.
//!
//! Silent tag failures are the most common complaint against the anchor tools (a room called
//! `Kitchen_Room ` is simply not a room, and nobody says so). A name is a near miss when a
//! small, typical slip (stray whitespace, Blender's `.001` duplicate suffix, the wrong
//! separator, the wrong case) is all that stands between it and a rule; the fix is then that
//! corrected name, which we can show. A misspelt tag word (`lounge-rooom`, `Kitchen_rom`) is
//! found by its edit distance to the literal prefixes and suffixes of the name rules.

use super::rules::{numbered_duplicate_stem, MatchOn, RuleSet, SEPARATORS};

/// A rule the name almost matched, and the name that would match it.
#[derive(Debug, Clone)]
pub(crate) struct Miss {
    pub rule: usize,
    pub suggestion: String,
    pub slip: &'static str,
    /// The material name that missed, for a material rule's near miss (else the node's name).
    pub material: Option<String>,
}

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
    numbered_duplicate_stem(s).unwrap_or(s).to_string()
}

/// A name whose first or last word is a rule's affix misspelt (within one edit, two for
/// words of seven letters or more, the first letter right, case ignored), with the name that
/// rule accepts.
fn misspelt_affix(rules: &RuleSet, name: &str) -> Option<Miss> {
    let name = strip_duplicate_suffix(name.trim());
    let lower = name.to_lowercase();
    for a in &rules.affixes {
        // The word at the affix's end of the name, and the rest.
        let cut = if a.prefix {
            lower.find(SEPARATORS)
        } else {
            lower.rfind(SEPARATORS)
        };
        let Some(cut) = cut else { continue };
        let (word, rest) = if a.prefix {
            (&lower[..cut], &name[cut + 1..])
        } else {
            (&lower[cut + 1..], &name[..cut])
        };
        // A slip keeps the word's first letter: `Broom_cupboard` is not `room_cupboard`.
        if rest.is_empty() || word == a.word || word.chars().next() != a.word.chars().next() {
            continue;
        }
        let allowed = if a.word.chars().count() >= 7 { 2 } else { 1 };
        if strsim::damerau_levenshtein(word, &a.word) > allowed {
            continue;
        }
        let suggestion = if a.prefix {
            format!("{}{}{rest}", a.word, a.separator)
        } else {
            format!("{rest}{}{}", a.separator, a.word)
        };
        if let Some(m) = rules
            .match_text(MatchOn::Name, &suggestion)
            .filter(|m| m.rule == a.rule)
        {
            return Some(Miss {
                rule: m.rule,
                suggestion,
                slip: "a misspelt tag word",
                material: None,
            });
        }
    }
    None
}

/// The rule `name` narrowly misses, if any. Call only for names no rule accepts.
pub fn check(rules: &RuleSet, name: &str) -> Option<Miss> {
    variants(name)
        .into_iter()
        .find_map(|(v, slip)| {
            rules.match_text(MatchOn::Name, &v).map(|m| Miss {
                rule: m.rule,
                suggestion: v,
                slip,
                material: None,
            })
        })
        .or_else(|| misspelt_affix(rules, name))
}

/// The material rule a material name narrowly misses, if any: the typical slips of
/// [`check`], or the last part of its path (after any folder) within an edit or two of the
/// last part of a material rule's example (`visportl` for `textures/editor/visportal`), the
/// first letter right. A misspelt portal material is a door silently closed, so it is said.
/// Call only for materials no rule accepts.
pub(crate) fn check_material(rules: &RuleSet, material: &str) -> Option<Miss> {
    if let Some(m) = variants(material).into_iter().find_map(|(v, slip)| {
        rules.match_text(MatchOn::Material, &v).map(|m| Miss {
            rule: m.rule,
            suggestion: v,
            slip,
            material: Some(material.to_string()),
        })
    }) {
        return Some(m);
    }
    let base = strip_duplicate_suffix(material.trim());
    let (folder, last) = match base.rfind('/') {
        Some(i) => (&base[..=i], &base[i + 1..]),
        None => ("", base.as_str()),
    };
    let word = last.to_lowercase();
    for (i, words) in &rules.material_words {
        let i = *i;
        for want in words {
            if word == *want || word.chars().next() != want.chars().next() {
                continue;
            }
            let allowed = if want.chars().count() >= 7 { 2 } else { 1 };
            if strsim::damerau_levenshtein(&word, want) > allowed {
                continue;
            }
            let suggestion = format!("{folder}{want}");
            if rules
                .match_text(MatchOn::Material, &suggestion)
                .is_some_and(|m| m.rule == i)
            {
                return Some(Miss {
                    rule: i,
                    suggestion,
                    slip: "a misspelt tag word",
                    material: Some(material.to_string()),
                });
            }
        }
    }
    None
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
    fn misspelt_tag_words_are_caught_by_edit_distance() {
        let r = default_rules();
        for (name, rule, fix) in [
            ("lounge-rooom", "godot.room", "lounge-room"),
            ("Kitchen_rom", "godot.room", "Kitchen-room"),
            ("Kitchen-Rom", "godot.room", "Kitchen-room"),
            ("hall-protal", "godot.portal", "hall-portal"),
            ("rom_kitchen", "lportal.room", "room_kitchen"),
            ("outside-roomgrup", "godot.roomgroup", "outside-roomgroup"),
            ("kitchen-rooms", "godot.room", "kitchen-room"),
        ] {
            let m = check(&r, name).unwrap_or_else(|| panic!("{name}: no near miss"));
            assert_eq!(r.rules[m.rule].spec.id, rule, "{name}");
            assert_eq!(m.suggestion, fix, "{name}");
        }
    }

    #[test]
    fn every_name_rule_of_the_presets_has_its_affix() {
        let r = default_rules();
        let words: Vec<(&str, bool)> = r
            .affixes
            .iter()
            .map(|a| (a.word.as_str(), a.prefix))
            .collect();
        for w in [
            ("room", false),
            ("portal", false),
            ("room", true),
            ("bound", true),
        ] {
            assert!(words.contains(&w), "{w:?} missing from {words:?}");
        }
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
            "Door_frame",
            "Bedroom",
            "Wall_Door_Centre.001",
            "Floor_tiles",
            "Mushroom",
            "Broom_cupboard",
            "Store-broom",
        ] {
            assert!(check(&r, n).is_none(), "{n} flagged");
        }
    }

    #[test]
    fn numbered_duplicates_are_tags_not_near_misses() {
        let r = default_rules();
        for name in ["kitchen-room.001", "lounge-portal.002"] {
            assert!(r.match_text(MatchOn::Name, name).is_some(), "{name}");
        }
        for material in ["portal.001", "textures/editor/visportal", "nodraw.003"] {
            assert!(
                r.match_text(MatchOn::Material, material).is_some(),
                "{material}"
            );
        }
        assert!(r.match_text(MatchOn::Name, "kitchen-room.5").is_none());
    }

    #[test]
    fn misspelt_portal_and_tool_materials_are_caught() {
        let r = default_rules();
        for (material, want) in [
            ("visportl", "visportal"),
            ("textures/editor/visportl", "textures/editor/visportal"),
            ("Portal ", "Portal"),
            ("textures/common/cualk", "textures/common/caulk"),
        ] {
            let m = check_material(&r, material).unwrap_or_else(|| panic!("{material}"));
            assert_eq!(m.suggestion, want, "{material}");
        }
        for ordinary in ["concrete", "wall_portrait", "brick/red", "plaster", "sky"] {
            assert!(check_material(&r, ordinary).is_none(), "{ordinary} flagged");
        }
    }

    #[test]
    fn duplicate_suffix_only_strips_three_digits() {
        assert_eq!(strip_duplicate_suffix("a.001"), "a");
        assert_eq!(strip_duplicate_suffix("a.5"), "a.5");
    }
}
