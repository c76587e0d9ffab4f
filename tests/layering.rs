//! The dependency order of docs/architecture.md ("Layers"), kept: every `crate::` path in
//! a module's code (comments and `#[cfg(test)]` parts aside) names a module of its own
//! layer or of a lower one. Run by `cargo test`; a new upward import fails here with its
//! file and line.

use std::path::{Path, PathBuf};

/// The layers from the bottom; a module may use its own layer's and lower ones'.
const LAYERS: &[&[&str]] = &[
    &["interrupt", "method"],
    // The system's description: the checked scenario and the model compiled from it share
    // their vocabulary (terms, names, admissibility) and are one layer.
    &["scenario", "model"],
    &["ident", "sim", "stats"],
    &["zoo"],
    &["report", "io"],
    &["estimators"],
    &["pipeline"],
];

/// Upward imports not cut yet, each with its reason; the test fails when one of them
/// disappears too, so the list stays exact.
const KNOWN_UPWARD: &[(&str, &str, &str)] = &[];

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// `(line, to)` of every `crate::to` in `text`, code of a module of layer `own`, that
/// names a higher layer (comments and `#[cfg(test)]` parts aside).
fn scan(text: &str, own: usize) -> Vec<(usize, String)> {
    let code = text.split("#[cfg(test)]").next().unwrap();
    let mut found = Vec::new();
    for (i, line) in code.lines().enumerate() {
        if line.trim_start().starts_with("//") {
            continue;
        }
        for (k, _) in line.match_indices("crate::") {
            let target: String = line[k + 7..]
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if layer_of(&target).is_some_and(|t| t > own) {
                found.push((i + 1, target));
            }
        }
    }
    found
}

/// `(file, line, from, to)` of every upward `crate::` path in the library's sources.
fn upward_imports() -> Vec<(String, usize, String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    let mut found = Vec::new();
    for f in files {
        let rel = f.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/");
        let module = rel
            .trim_start_matches("src/")
            .split('/')
            .next()
            .unwrap()
            .trim_end_matches(".rs")
            .to_string();
        // The binary's cli, lib.rs and main.rs are the top; test modules may reach up.
        let Some(own) = layer_of(&module) else { continue };
        if rel.ends_with("/tests.rs") {
            continue;
        }
        for (line, to) in scan(&std::fs::read_to_string(&f).unwrap(), own) {
            found.push((rel.clone(), line, module.clone(), to));
        }
    }
    found
}

#[test]
fn no_module_imports_from_a_higher_layer() {
    let found = upward_imports();
    let unexpected: Vec<String> = found
        .iter()
        .filter(|(f, _, _, to)| !KNOWN_UPWARD.iter().any(|(kf, kt, _)| kf == f && kt == to))
        .map(|(f, l, from, to)| format!("{f}:{l}: {from} uses {to}, a higher layer"))
        .collect();
    assert!(
        unexpected.is_empty(),
        "upward imports (docs/architecture.md, \"Layers\"):\n{}",
        unexpected.join("\n")
    );
    for (f, to, why) in KNOWN_UPWARD {
        assert!(
            found.iter().any(|(ff, _, _, t)| ff == f && t == to),
            "{f} no longer uses {to} ({why}): take it off KNOWN_UPWARD"
        );
    }
}

#[test]
fn the_scan_finds_an_upward_path_and_skips_comments_and_tests() {
    let io = layer_of("io").unwrap();
    let text = "use crate::ident::Problem;\n\
                // crate::pipeline in a comment\n\
                let n = crate::pipeline::Input::LOOK_EVERY; /* crate::estimators */\n\
                #[cfg(test)]\n\
                use crate::pipeline::Options;\n";
    assert_eq!(
        scan(text, io),
        [(3, "pipeline".to_string()), (3, "estimators".to_string())]
    );
}

/// Lines a source file of the library, the binary or the tests may have: a file longer
/// than this holds more than one thing (docs/architecture.md; functions are held to 150
/// lines by clippy's `too_many_lines`, clippy.toml).
const MAX_FILE_LINES: usize = 900;

#[test]
fn no_source_file_is_longer_than_its_limit() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for dir in ["src", "tests", "benches"] {
        rust_files(&root.join(dir), &mut files);
    }
    let long: Vec<String> = files
        .iter()
        .filter_map(|f| {
            let n = std::fs::read_to_string(f).unwrap().lines().count();
            (n > MAX_FILE_LINES).then(|| format!("{} ({n} lines)", f.strip_prefix(root).unwrap().display()))
        })
        .collect();
    assert!(
        long.is_empty(),
        "over {MAX_FILE_LINES} lines, split by what each part is for: {long:?}"
    );
}
