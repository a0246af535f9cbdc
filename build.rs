//! Records the compiler version for results manifests (provenance), and builds the NLopt that
//! slamlab links: the `nlopt` crate's copy with TNEWTON's uninitialised reads fixed
//! (`build/nlopt_patch.rs`).
use std::process::Command;

#[path = "build/nlopt_patch.rs"]
mod nlopt_patch;

fn main() {
    nlopt_patch::build();
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let version = Command::new(rustc)
        .arg("--version")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=SLAMLAB_RUSTC_VERSION={version}");
    println!("cargo:rerun-if-env-changed=RUSTC");
    println!("cargo:rerun-if-changed=build.rs");
}
