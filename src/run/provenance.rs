//! Where results come from: crate and compiler versions, and the git commit of the inputs.

use std::path::Path;
use std::process::Command;

/// Paths whose contents determine results and reports. The commit recorded is the last one that
/// touched them, so committing regenerated reports does not itself change the provenance.
pub const INPUT_PATHS: &[&str] =
    &["src", "build.rs", "Cargo.toml", "Cargo.lock", "data/maps", "experiments", "templates"];

#[derive(Debug, Clone, PartialEq)]
pub struct Provenance {
    pub crate_version: String,
    pub rustc: String,
    pub git_commit: String,
    pub git_dirty: bool,
}

impl Provenance {
    /// Reads git state of `root` (the repository); without git, the commit is `unknown`.
    pub fn collect(root: &Path) -> Provenance {
        let git = |args: &[&str]| -> Option<String> {
            let out = Command::new("git")
                .arg("-C")
                .arg(root)
                .args(args)
                .args(["--"])
                .args(INPUT_PATHS)
                .output()
                .ok()?;
            out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
        };
        let commit = git(&["log", "-1", "--format=%H"]).filter(|c| !c.is_empty());
        let dirty = commit.is_some()
            && git(&["status", "--porcelain", "--untracked-files=normal"])
                .is_some_and(|s| !s.is_empty());
        Provenance {
            crate_version: env!("CARGO_PKG_VERSION").to_string(),
            rustc: env!("SLAMLAB_RUSTC_VERSION").to_string(),
            git_commit: commit.unwrap_or_else(|| "unknown".into()),
            git_dirty: dirty,
        }
    }
}
