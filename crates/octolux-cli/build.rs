//! Records the git commit the binary is built from (`OCTOLUX_COMMIT`), so that `bench` JSON
//! says which code measured it. `unknown` outside a git checkout; `+dirty` when tracked files
//! differ from the commit.
use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    // Rerun when the commit moves or a source the binary is made of changes (cargo compares
    // the folders' modification times recursively).
    if let Some(git_dir) = git(&["rev-parse", "--absolute-git-dir"]) {
        // Only files that exist: cargo reruns the script every build for a missing one.
        for file in ["HEAD", "index", "packed-refs", "refs/heads"] {
            let path = std::path::Path::new(&git_dir).join(file);
            if path.exists() {
                println!("cargo:rerun-if-changed={}", path.display());
            }
        }
    }
    for dir in ["src", "../octolux/src", "../../scenes"] {
        println!("cargo:rerun-if-changed={dir}");
    }
    let commit = match git(&["rev-parse", "HEAD"]) {
        Some(hash) if !hash.is_empty() => {
            let dirty = git(&["status", "--porcelain", "--untracked-files=no"])
                .is_some_and(|s| !s.is_empty());
            format!("{hash}{}", if dirty { "+dirty" } else { "" })
        }
        _ => "unknown".to_string(),
    };
    println!("cargo:rustc-env=OCTOLUX_COMMIT={commit}");
}
