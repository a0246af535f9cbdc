//! `data/algorithms/<name>.toml` → the [`Catalogue`] a study's names resolve against: the
//! built-ins and each declared external program (docs/src/guide/external-algorithms.md). Every problem is
//! reported with file, line and key; the files a descriptor lists are read and hashed here, so
//! that editing the program recomputes its runs.

use super::{InputErrors, SpecError};
use crate::algo::Catalogue;
use crate::algo::external::{Descriptor, ExternalSpec};
use crate::params::Params;
use crate::source::{Locator, SourceError};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The built-ins and the external algorithms declared in `dirs` (a folder that does not exist
/// declares none). Paths inside a descriptor (`files`, the command) are relative to the working
/// directory, the repository, as map files' data paths are.
pub fn catalogue(dirs: &[PathBuf]) -> Result<Arc<Catalogue>, InputErrors> {
    let mut paths = Vec::new();
    for dir in dirs {
        let mut here: Vec<PathBuf> = match std::fs::read_dir(dir) {
            Ok(entries) => entries
                .flatten()
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x == "toml"))
                .collect(),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
            Err(e) => return Err(SpecError::io(dir, &e).into()),
        };
        here.sort();
        paths.extend(here);
    }
    let mut externals: Vec<ExternalSpec> = Vec::new();
    let mut errors = Vec::new();
    for path in &paths {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) => {
                errors.push(SpecError::io(path, &e));
                continue;
            }
        };
        let read = |file: &str| std::fs::read(file).map_err(|e| e.to_string());
        match external(path, &text, &read) {
            Ok(e) if externals.iter().any(|o| o.name == e.name) => {
                let locator = Locator::new(&text);
                let why = format!("another folder of --algorithms declares `{}` too", e.name);
                errors
                    .push(SpecError::new(path, vec![SourceError::at_key(&locator, "title", why)]));
            }
            Ok(e) => externals.push(e),
            Err(e) => errors.push(SpecError::new(path, e)),
        }
    }
    if !errors.is_empty() {
        return Err(InputErrors(errors));
    }
    Ok(Arc::new(Catalogue::with_externals(externals)))
}

/// One descriptor: parsed, checked, and its listed files hashed (`read` reads one by path).
pub fn external(
    path: &Path,
    text: &str,
    read: &dyn Fn(&str) -> Result<Vec<u8>, String>,
) -> Result<ExternalSpec, Vec<SourceError>> {
    let locator = Locator::new(text);
    let descriptor: Descriptor =
        toml::from_str(text).map_err(|e| vec![SourceError::from_toml(&locator, &e)])?;
    let mut errors = Vec::new();
    let mut err = |key: &str, m: String| errors.push(SourceError::at_key(&locator, key, m));
    let name = path.file_stem().unwrap_or_default().to_string_lossy().to_string();
    if name.is_empty()
        || !name.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
    {
        err(
            "title",
            format!(
                "the file's name `{name}` is the algorithm's name: use lower-case letters, digits and `_`"
            ),
        );
    }
    if Catalogue::builtin().get(&name).is_some() {
        err("title", format!("`{name}` is a built-in algorithm's name: name the file otherwise"));
    }
    for (key, value) in [
        ("title", &descriptor.title),
        ("version", &descriptor.version),
        ("description", &descriptor.description),
    ] {
        if value.trim().is_empty() {
            err(key, "must not be empty".into());
        }
    }
    if descriptor.command.first().is_none_or(|c| c.trim().is_empty()) {
        err("command", "give the program and its arguments, e.g. [\"python3\", \"my_slam.py\", \"{input}\", \"{output}\"]".into());
    }
    if !(descriptor.timeout_s.is_finite() && descriptor.timeout_s > 0.0) {
        err(
            "timeout_s",
            format!("must be a positive number of seconds, got {}", descriptor.timeout_s),
        );
    }
    if !(descriptor.expected_s.is_finite() && descriptor.expected_s >= 0.0) {
        err("expected_s", format!("must be a finite number ≥ 0, got {}", descriptor.expected_s));
    }
    for (i, r) in descriptor.reads.iter().enumerate() {
        if descriptor.reads[..i].contains(r) {
            err(&format!("reads[{i}]"), "is listed twice".into());
        }
    }
    let sections: Vec<String> = Params::default().to_table().keys().cloned().collect();
    for (i, s) in descriptor.sections.iter().enumerate() {
        if !sections.contains(s) {
            err(
                &format!("sections[{i}]"),
                format!("unknown [base] section `{s}` (sections: {})", sections.join(", ")),
            );
        }
    }
    let mut files = Vec::new();
    for (i, f) in descriptor.files.iter().enumerate() {
        match read(f) {
            Ok(bytes) => files.push((f.clone(), bytes)),
            Err(why) => err(&format!("files[{i}]"), format!("cannot read `{f}`: {why}")),
        }
    }
    if !errors.is_empty() {
        return Err(errors);
    }
    let content_hash = ExternalSpec::hash_of(&descriptor, &files);
    Ok(ExternalSpec { name, content_hash, descriptor })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::Algorithm;

    const GOOD: &str = "title = \"Mine\"\nversion = \"1\"\ncommand = [\"python3\", \"mine.py\", \"{input}\", \"{output}\"]\nfiles = [\"mine.py\"]\nreads = [\"landmarks\"]\nsections = [\"motion_model\"]\ndescription = \"An EKF.\"\n";

    fn read_ok(_: &str) -> Result<Vec<u8>, String> {
        Ok(b"print('hello')".to_vec())
    }

    #[test]
    fn a_descriptor_becomes_an_algorithm_whose_version_follows_its_files() {
        let e = external(Path::new("data/algorithms/mine.toml"), GOOD, &read_ok).unwrap();
        assert_eq!(e.name(), "mine");
        assert_eq!(e.sections(crate::world::WorldKind::Points), ["motion_model", "external.mine"]);
        let edited =
            external(Path::new("mine.toml"), GOOD, &|_| Ok(b"print('bye')".to_vec())).unwrap();
        assert_ne!(
            e.code_version(),
            edited.code_version(),
            "an edited program must not hit the cache"
        );
        let bumped = external(
            Path::new("mine.toml"),
            &GOOD.replace("version = \"1\"", "version = \"2\""),
            &read_ok,
        )
        .unwrap();
        assert_ne!(e.code_version(), bumped.code_version());
    }

    #[test]
    fn descriptor_errors_name_line_and_key() {
        let bad = |text: &str, path: &str| external(Path::new(path), text, &read_ok).unwrap_err();
        let e = bad(&GOOD.replace("reads", "raeds"), "mine.toml");
        assert!(e[0].message.contains("unknown field `raeds`") && e[0].line == 5, "{:?}", e[0]);
        let e = bad(&GOOD.replace("[\"motion_model\"]", "[\"motion\"]"), "mine.toml");
        assert!(
            e[0].key == "sections[0]" && e[0].message.contains("unknown [base] section `motion`"),
            "{:?}",
            e[0]
        );
        let e = bad(GOOD, "fastslam1.toml");
        assert!(e[0].message.contains("built-in"), "{:?}", e[0]);
        let e = bad(
            &GOOD.replace(
                "command = [\"python3\", \"mine.py\", \"{input}\", \"{output}\"]",
                "command = []",
            ),
            "mine.toml",
        );
        assert_eq!(e[0].key, "command");
        let e = external(Path::new("mine.toml"), GOOD, &|f| Err(format!("no such file {f}")))
            .unwrap_err();
        assert!(e[0].key == "files[0]" && e[0].line == 4, "{:?}", e[0]);
    }
}
