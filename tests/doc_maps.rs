//! The docs' maps against the tree: every relative link and anchor of the README, docs/ and
//! the folders' indexes resolves; the README lists every shipped scenario, study, model
//! file and command; every document over 150 lines opens with its contents. (The docs'
//! commands themselves are run by `tests/docs/run_examples.py` in CI.)

use crate::common::files_in;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The markdown files a reader meets: the README, docs/, and the folders' indexes.
fn documents() -> Vec<PathBuf> {
    let mut docs = vec![PathBuf::from("README.md"), PathBuf::from("CHANGELOG.md")];
    docs.extend(files_in("docs", ".md"));
    for index in ["data/README.md", "models/README.md", "studies/README.md"] {
        docs.push(PathBuf::from(index));
    }
    docs
}

/// Lines outside fenced code blocks, with their 1-based numbers.
fn prose(text: &str) -> Vec<(usize, &str)> {
    let mut fenced = false;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if !fenced {
            out.push((i + 1, line));
        }
    }
    out
}

/// GitHub's anchor of a heading: lower case, spaces to `-`, punctuation dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '_' || c == '-' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a document's headings (a repeated heading gets `-1`, `-2`, … as on GitHub).
fn anchors(text: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    for (_, line) in prose(text) {
        let Some(heading) = line.strip_prefix('#') else {
            continue;
        };
        let heading = heading.trim_start_matches('#');
        if !heading.starts_with(' ') {
            continue;
        }
        let base = slug(heading);
        let mut anchor = base.clone();
        let mut n = 0;
        while seen.contains(&anchor) {
            n += 1;
            anchor = format!("{base}-{n}");
        }
        seen.insert(anchor);
    }
    seen
}

/// The targets of the inline links `[text](target)` in the prose, with their line numbers.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (n, line) in prose(text) {
        let mut rest = line;
        while let Some(i) = rest.find("](") {
            let after = &rest[i + 2..];
            let Some(end) = after.find(')') else { break };
            out.push((n, after[..end].to_string()));
            rest = &after[end..];
        }
    }
    out
}

#[test]
fn every_relative_link_and_anchor_resolves() {
    let mut broken = Vec::new();
    for doc in documents() {
        let text = std::fs::read_to_string(&doc).unwrap();
        for (line, target) in links(&text) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (path, anchor) = match target.split_once('#') {
                Some((p, a)) => (p, Some(a)),
                None => (target.as_str(), None),
            };
            let file = if path.is_empty() {
                doc.clone()
            } else {
                doc.parent().unwrap_or(Path::new("")).join(path)
            };
            if !file.exists() {
                broken.push(format!("{}:{line}: {target}: no such file", doc.display()));
                continue;
            }
            if let Some(anchor) = anchor {
                let target_text = std::fs::read_to_string(&file).unwrap_or_default();
                if !anchors(&target_text).contains(anchor) {
                    broken.push(format!(
                        "{}:{line}: {target}: no heading of {} has that anchor",
                        doc.display(),
                        file.display()
                    ));
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

/// The names of the files of `dir` ending in `ext`, sorted.
fn names_in(dir: &str, ext: &str) -> Vec<String> {
    files_in(dir, ext)
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect()
}

#[test]
fn the_readme_lists_every_shipped_scenario_study_model_and_table() {
    let readme = std::fs::read_to_string("README.md").unwrap();
    let mut missing = Vec::new();
    for name in names_in("scenarios", ".toml") {
        if !readme.contains(&format!("| `{name}` |")) {
            missing.push(format!("scenarios/{name} (a row of the scenario table)"));
        }
    }
    for name in names_in("studies", ".toml") {
        let stem = name.trim_end_matches(".toml");
        if !readme.contains(&format!("`{stem}`")) {
            missing.push(format!("studies/{name}"));
        }
    }
    for name in names_in("models", ".toml") {
        if !readme.contains(&format!("`{name}`")) {
            missing.push(format!("models/{name}"));
        }
    }
    for name in names_in("data", ".csv") {
        if !readme.contains(&format!("data/{name}")) {
            missing.push(format!("data/{name}"));
        }
    }
    assert!(missing.is_empty(), "not in the README: {missing:?}");
    // The folders' indexes list their files too.
    for (dir, ext) in [("studies", ".toml"), ("models", ".toml"), ("data", ".csv")] {
        let index = std::fs::read_to_string(format!("{dir}/README.md")).unwrap();
        for name in names_in(dir, ext) {
            assert!(index.contains(&format!("`{name}`")), "{dir}/README.md lacks {name}");
        }
    }
}

/// The subcommands `--help` lists (the first word of each line of its "Commands:" section).
fn subcommands(args: &[&str]) -> Vec<String> {
    let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args(args)
        .arg("--help")
        .output()
        .unwrap();
    let help = String::from_utf8(out.stdout).unwrap();
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|c| c != "help")
        .collect()
}

#[test]
fn the_readme_lists_every_command() {
    let readme = std::fs::read_to_string("README.md").unwrap();
    let mut commands: Vec<Vec<String>> = subcommands(&[]).into_iter().map(|c| vec![c]).collect();
    assert!(commands.len() >= 6, "{commands:?}");
    for parent in commands.clone() {
        for sub in subcommands(&[parent[0].as_str()]) {
            commands.push(vec![parent[0].clone(), sub]);
        }
    }
    let missing: Vec<String> = commands
        .iter()
        .map(|c| format!("fpkbench {}", c.join(" ")))
        .filter(|c| !readme.contains(&format!("| `{c}")))
        .collect();
    assert!(missing.is_empty(), "not in the README's command table: {missing:?}");
}

#[test]
fn every_long_document_opens_with_its_contents() {
    for doc in documents() {
        let text = std::fs::read_to_string(&doc).unwrap();
        if !doc.starts_with("docs") || text.lines().count() <= 150 {
            continue;
        }
        let lines = prose(&text);
        let first_section = lines
            .iter()
            .position(|(_, l)| l.starts_with("## "))
            .unwrap_or(lines.len());
        let start = lines[..first_section]
            .iter()
            .position(|(_, l)| l.starts_with("Contents:"));
        let Some(start) = start else {
            panic!(
                "{} has {} lines and no `Contents:` before its first section",
                doc.display(),
                text.lines().count()
            );
        };
        let contents: String = lines[start..first_section]
            .iter()
            .take_while(|(_, l)| !l.is_empty())
            .map(|(_, l)| *l)
            .collect::<Vec<_>>()
            .join(" ");
        for (_, line) in &lines {
            if let Some(heading) = line.strip_prefix("## ") {
                assert!(
                    contents.contains(&format!("(#{})", slug(heading))),
                    "{}: the contents lack the section `{heading}`",
                    doc.display()
                );
            }
        }
    }
}
