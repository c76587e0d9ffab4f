//! Records the git commit the binary is built from (`FPKBENCH_GIT_COMMIT`, empty outside a
//! git checkout or without git), for the provenance in `report.json`.

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    let commit = git(&["rev-parse", "HEAD"]).map(|c| {
        // `--no-optional-locks`: the status must not refresh and rewrite `.git/index`, which
        // this script watches; otherwise every build would make the next one rebuild the crate.
        let dirty = git(&["--no-optional-locks", "status", "--porcelain", "--untracked-files=no"])
            .is_some_and(|s| !s.is_empty());
        if dirty {
            format!("{c}-dirty")
        } else {
            c
        }
    });
    println!("cargo:rustc-env=FPKBENCH_GIT_COMMIT={}", commit.unwrap_or_default());
    // Rebuild when HEAD moves or the index changes (a commit, a checkout).
    let mut watch = vec![".git/HEAD".to_string(), ".git/index".to_string()];
    if let Ok(head) = std::fs::read_to_string(".git/HEAD") {
        if let Some(r) = head.trim().strip_prefix("ref: ") {
            watch.push(format!(".git/{r}"));
        }
    }
    for f in watch {
        if std::path::Path::new(&f).exists() {
            println!("cargo:rerun-if-changed={f}");
        }
    }
    println!("cargo:rerun-if-changed=build.rs");
}
