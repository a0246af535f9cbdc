//! NLopt's TNEWTON made independent of the heap: the NLopt that slamlab links is the `nlopt`
//! crate's own copy of NLopt 2.9.1 with two lines changed, built here at build time.
//!
//! Lukšan's PNET (`src/algs/luksan/pnet.c`, NLopt's `LD_TNEWTON*`) reads memory it never wrote:
//! - `mx`, the number of stored correction pairs, is a local read before it is set on the first
//!   iteration when no restart is triggered (`PRECOND_RESTART`, `mos2 = 2`);
//! - with it, the columns `xm`, `gm`, `u1`, `u2` of the `malloc`ed work array, of which NLopt
//!   zeroes only `xo`.
//!
//! The point it evaluates then depends on whatever the heap held before (valgrind memcheck:
//! conditional jump at `pnet.c:395`, uninitialised values reaching the objective at `:398`).
//! Initialising both to zero is what the Fortran original's `ALLOCATE` is assumed to give (the
//! comment above NLopt's own `memset` of `xo`) and what the first iteration after a restart sees
//! (`mx = 0`). NLopt's upstream `pnet.c` (2.11 development) is unchanged here.
//!
//! How: the `nlopt` crate builds its bundled copy as a static library `nlopt`. This script finds
//! that copy's source through `cargo metadata`, copies it into `OUT_DIR`, applies [`EDITS`] (each
//! must match exactly once, or the build stops), builds it with the same CMake options as the
//! crate, and links it as `nlopt_zeroed` with `+whole-archive`. Every NLopt symbol is then defined
//! before the linker reaches the crate's library, so none of that library's objects is pulled in;
//! were one pulled in, the link would fail on duplicate symbols rather than mix the two silently.
//! No NLopt code is committed to this repository: only the edits below.

use std::path::{Path, PathBuf};
use std::process::Command;

/// One edit of NLopt's source: the file, the exact text it replaces (found exactly once) and
/// the replacement.
struct Edit {
    file: &'static str,
    from: &'static str,
    to: &'static str,
}

/// The whole patch.
const EDITS: &[Edit] = &[
    Edit {
        file: "src/algs/luksan/pnet.c",
        from: "    int mx, kbf;\n",
        to: "    int mx = 0, kbf; /* slamlab: read before set when no restart is triggered */\n",
    },
    Edit {
        file: "src/algs/luksan/pnet.c",
        from: "     work = (double*) malloc(sizeof(double) * (n * 9 + MAX2(n,n*mf)*2 +\n",
        to: "     work = (double*) calloc(1, sizeof(double) * (n * 9 + MAX2(n,n*mf)*2 + /* slamlab: zeroed */\n",
    },
];

/// The NLopt version the `nlopt` crate bundles and the edits were written against.
const NLOPT_DIR: &str = "nlopt-2.9.1";

pub fn build() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR"));
    let source = bundled_source();
    let copy = out.join(NLOPT_DIR);
    if copy.exists() {
        std::fs::remove_dir_all(&copy).expect("remove the previous patched NLopt copy");
    }
    copy_tree(&source, &copy);
    for edit in EDITS {
        apply(&copy, edit);
    }
    // The `nlopt` crate's options (its build.rs), so both builds compile the same objects.
    let dst = cmake::Config::new(&copy)
        .define("BUILD_SHARED_LIBS", "OFF")
        .define("NLOPT_CXX", "OFF")
        .define("NLOPT_PYTHON", "OFF")
        .define("NLOPT_OCTAVE", "OFF")
        .define("NLOPT_MATLAB", "OFF")
        .define("NLOPT_GUILE", "OFF")
        .define("NLOPT_SWIG", "OFF")
        .define("NLOPT_LINK_PYTHON", "OFF")
        .out_dir(out.join("nlopt-build"))
        .build();
    let built = ["lib", "lib64"]
        .iter()
        .map(|d| dst.join(d).join("libnlopt.a"))
        .find(|p| p.exists())
        .expect("the patched NLopt build produced no libnlopt.a");
    // A name of its own, so the linker cannot confuse it with the crate's `libnlopt.a`.
    let lib_dir = out.join("nlopt-zeroed");
    std::fs::create_dir_all(&lib_dir).expect("create the patched NLopt library folder");
    std::fs::copy(&built, lib_dir.join("libnlopt_zeroed.a")).expect("copy libnlopt.a");
    println!("cargo:rustc-link-search=native={}", lib_dir.display());
    println!("cargo:rustc-link-lib=static:+whole-archive=nlopt_zeroed");
    println!("cargo:rerun-if-changed=build/nlopt_patch.rs");
}

/// The folder of the `nlopt` crate's bundled NLopt source, as `cargo metadata` locates the crate.
fn bundled_source() -> PathBuf {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let manifest =
        PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"))
            .join("Cargo.toml");
    let output = Command::new(cargo)
        .args(["metadata", "--format-version", "1", "--offline", "--locked", "--manifest-path"])
        .arg(&manifest)
        // Only this target's packages: those are the ones downloaded, as `--offline` needs.
        .arg("--filter-platform")
        .arg(std::env::var("TARGET").expect("TARGET"))
        .output()
        .expect("run cargo metadata to locate the nlopt crate's NLopt source");
    assert!(
        output.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let metadata: serde_json::Value =
        serde_json::from_slice(&output.stdout).expect("cargo metadata printed JSON");
    let packages = metadata["packages"].as_array().expect("cargo metadata lists packages");
    let nlopt: Vec<&serde_json::Value> = packages.iter().filter(|p| p["name"] == "nlopt").collect();
    assert_eq!(nlopt.len(), 1, "exactly one `nlopt` package in the dependency graph");
    let manifest_path = nlopt[0]["manifest_path"].as_str().expect("nlopt's manifest_path");
    let source = Path::new(manifest_path).parent().expect("nlopt's folder").join(NLOPT_DIR);
    assert!(
        source.join("CMakeLists.txt").exists(),
        "the nlopt crate no longer bundles {NLOPT_DIR} at {}: review build/nlopt_patch.rs's edits \
         against the new NLopt before updating NLOPT_DIR",
        source.display()
    );
    source
}

/// Applies one edit, stopping the build unless its text occurs exactly once.
fn apply(root: &Path, edit: &Edit) {
    let path = root.join(edit.file);
    let text = std::fs::read_to_string(&path).expect("read the file to patch");
    let found = text.matches(edit.from).count();
    assert!(
        found == 1,
        "{}: the text to replace occurs {found} times, not once: NLopt changed, review \
         build/nlopt_patch.rs\n{}",
        edit.file,
        edit.from
    );
    std::fs::write(&path, text.replacen(edit.from, edit.to, 1)).expect("write the patched file");
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("create a folder of the NLopt copy");
    for entry in std::fs::read_dir(from).expect("read NLopt's source folder") {
        let entry = entry.expect("read a folder entry");
        let target = to.join(entry.file_name());
        if entry.file_type().expect("file type").is_dir() {
            copy_tree(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).expect("copy an NLopt source file");
        }
    }
}
