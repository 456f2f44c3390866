//! ericw-tools vis's command line, as mappers' build scripts and editor compile profiles
//! type it (`vis -fast -threads 2 map.bsp`), turned into `vis`'s own before clap reads it.
//! Only the words after the `vis` subcommand are touched, and only single-dash words: a
//! known ericw option becomes its `--` spelling (or is dropped when it says nothing here,
//! or marked refused when portcullis cannot do what it asks); a single-dash spelling of one
//! of `vis`'s own long options gets its second dash (`-method full`), and any other word is
//! refused by name. `--` spellings pass unchanged.

use std::ffi::OsString;

/// What an ericw option becomes.
enum Meaning {
    /// Our option of this name, with (`true`) or without a value.
    Ours(&'static str, bool),
    /// Nothing to do here; its value (if `true`) is taken with it.
    Ignored(bool),
    /// Not something portcullis does; its value (if `true`) is taken with it.
    Refused(bool),
}

fn meaning(word: &str) -> Option<Meaning> {
    use Meaning::*;
    Some(match word {
        "fast" => Ours("--fast", false),
        "level" => Ours("--level", true),
        "threads" => Ours("--threads", true),
        "noambient" | "noambientsky" | "noambientwater" | "noambientslime" | "noambientlava" => {
            return Some(Ours(
                match word {
                    "noambient" => "--noambient",
                    "noambientsky" => "--noambientsky",
                    "noambientwater" => "--noambientwater",
                    "noambientslime" => "--noambientslime",
                    _ => "--noambientlava",
                },
                false,
            ))
        }
        "v" | "verbose" => Ours("--verbose", false),
        "noverbose" | "quiet" => Ours("--quiet", false),
        "help" | "h" | "?" => Ours("--help", false),
        "nostate" | "autoclean" | "noautoclean" | "log" | "nolog" | "lowpriority"
        | "nolowpriority" | "nopercent" | "nostat" | "noprogress" | "nocolor" | "q2rtx"
        | "defaultpaths" | "nodefaultpaths" | "logappend" => Ignored(false),
        "gamedir"
        | "basedir"
        | "path"
        | "filepriority"
        | "targetchecks"
        | "tex_saturation_boost" => Ignored(true),
        "visdist" | "logfile" => Refused(true),
        "phsonly" | "rst" => Refused(false),
        _ => return None,
    })
}

/// Whether an ericw switch with this meaning reads an optional 0 / 1 / -1 after it.
fn is_switch(m: &Meaning) -> bool {
    matches!(
        m,
        Meaning::Ours(_, false) | Meaning::Ignored(false) | Meaning::Refused(false)
    )
}

/// The command line with `vis`'s single-dash words rewritten (see the module doc).
/// `ours`: the long options `vis` (and the command line around it) has.
pub fn rewrite(args: Vec<OsString>, ours: &std::collections::BTreeSet<String>) -> Vec<OsString> {
    let Some(at) = vis_position(&args) else {
        return args;
    };
    let mut out: Vec<OsString> = args[..=at].to_vec();
    let mut rest = args[at + 1..].iter().peekable();
    while let Some(a) = rest.next() {
        let Some(word) = a.to_str().and_then(single_dash_word) else {
            out.push(a.clone());
            if a == "--" {
                out.extend(rest.cloned());
                break;
            }
            continue;
        };
        let Some(m) = meaning(word) else {
            // One of ours with one dash (`-method full`), or nobody's: refused by name, as
            // clap would say `--word` and confuse whoever typed `-word`.
            out.push(if ours.contains(word) {
                format!("--{word}").into()
            } else {
                format!("--ericw-refused=-{word}").into()
            });
            continue;
        };
        // ericw switches take an optional 0 / 1 (-1 reads as 0) after them.
        let mut on = true;
        if is_switch(&m) {
            if let Some(v) = rest.peek().and_then(|v| v.to_str()) {
                if matches!(v, "0" | "1" | "-1") {
                    on = v == "1";
                    rest.next();
                }
            }
        }
        let typed = |value: Option<&OsString>| match value {
            Some(v) => format!("-{word} {}", v.to_string_lossy()),
            None => format!("-{word}"),
        };
        match m {
            Meaning::Ours("--threads", _) if rest.peek().is_some_and(|v| *v == "0") => {
                // ericw's -threads 0 is "automatic", which is ours without the option.
                rest.next();
            }
            Meaning::Ours(flag, value) => {
                if on {
                    out.push(flag.into());
                }
                if value {
                    out.extend(rest.next().cloned());
                }
            }
            Meaning::Ignored(value) => {
                let v = if value { rest.next() } else { None };
                out.push(format!("--ericw-ignored={}", typed(v)).into());
            }
            Meaning::Refused(value) => {
                let v = if value { rest.next() } else { None };
                out.push(format!("--ericw-refused={}", typed(v)).into());
            }
        }
    }
    out
}

/// Where the `vis` subcommand is: after the program and any global `--color` option.
fn vis_position(args: &[OsString]) -> Option<usize> {
    let mut i = 1;
    while let Some(a) = args.get(i) {
        if a == "--color" {
            i += 2;
        } else if a.to_str().is_some_and(|s| s.starts_with("--color=")) {
            i += 1;
        } else {
            break;
        }
    }
    (args.get(i)? == "vis").then_some(i)
}

/// `word` of a `-word` (one dash, then a letter, or `-?`); not `--word`, `-` or `-1`.
fn single_dash_word(a: &str) -> Option<&str> {
    let w = a.strip_prefix('-')?;
    let first = w.chars().next()?;
    if first.is_ascii_alphabetic() || w == "?" {
        // `-h` is clap's own already; the rest of the one-letter words are ericw's `-v`
        // or unknown, and go through `meaning`.
        Some(w)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(s: &str) -> Vec<OsString> {
        s.split_whitespace().map(OsString::from).collect()
    }
    fn shown(v: Vec<OsString>) -> String {
        v.iter()
            .map(|a| a.to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join(" ")
    }

    #[test]
    fn ericw_words_become_ours_for_vis_only() {
        let ours = ["method", "threads", "samples", "color"]
            .map(String::from)
            .into();
        let r = |s: &str| shown(rewrite(words(s), &ours));
        assert_eq!(
            r("portcullis vis -fast -threads 2 map.bsp"),
            "portcullis vis --fast --threads 2 map.bsp"
        );
        assert_eq!(
            r("portcullis --color never vis -v -level 4 m.bsp"),
            "portcullis --color never vis --verbose --level 4 m.bsp"
        );
        assert_eq!(
            r("portcullis vis -threads 0 -noambient 1 -fast 0 m.bsp"),
            "portcullis vis --noambient m.bsp"
        );
        assert_eq!(
            r("portcullis vis -nostate -basedir /q m.bsp"),
            "portcullis vis --ericw-ignored=-nostate --ericw-ignored=-basedir /q m.bsp"
        );
        assert_eq!(
            r("portcullis vis -visdist 500 m.bsp"),
            "portcullis vis --ericw-refused=-visdist 500 m.bsp"
        );
        assert_eq!(
            r("portcullis vis -method sampled --threads 2 m.prt"),
            "portcullis vis --method sampled --threads 2 m.prt"
        );
        assert_eq!(
            r("portcullis vis -- -fast.bsp"),
            "portcullis vis -- -fast.bsp"
        );
        // Other subcommands keep their words.
        assert_eq!(
            r("portcullis check -fast m.gltf"),
            "portcullis check -fast m.gltf"
        );
    }
}
