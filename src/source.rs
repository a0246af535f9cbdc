//! Locating keys in TOML text, so every config error can name file, line, column and key.
//!
//! [`Locator`] parses the text once with span information (`toml::de::DeTable`) and answers two
//! questions: where is the key `a.b[2].c` written, and which key encloses a byte offset (for
//! serde errors, which carry only a span).

use std::ops::Range;
use toml::de::{DeTable, DeValue};

/// Line and column, both 1-based.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LineCol {
    pub line: usize,
    pub column: usize,
}

/// Key paths of one TOML document with the byte spans of their keys and values.
#[derive(Debug, Clone, Default)]
pub struct Locator {
    line_starts: Vec<usize>,
    /// The text's lines, to name what a parse error points at (a duplicate key).
    lines: Vec<String>,
    /// (path, key span, value span), in document order.
    entries: Vec<(String, Range<usize>, Range<usize>)>,
    /// Path → its first entry: placing an error is a lookup, not a scan (a sweep of 10⁵ values
    /// can fail at every value).
    index: std::collections::HashMap<String, usize>,
}

impl Locator {
    /// Indexes `text`; text that does not parse yields a locator with line information only.
    pub fn new(text: &str) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        let mut entries = Vec::new();
        if let Ok(table) = DeTable::parse(text) {
            walk_table(table.get_ref(), "", &mut entries);
        }
        let mut index = std::collections::HashMap::with_capacity(entries.len());
        for (i, (path, ..)) in entries.iter().enumerate() {
            index.entry(path.clone()).or_insert(i);
        }
        Self { line_starts, entries, index, lines: text.lines().map(str::to_string).collect() }
    }

    pub fn line_col(&self, offset: usize) -> LineCol {
        let line = self.line_starts.partition_point(|&s| s <= offset);
        LineCol { line, column: offset - self.line_starts[line.max(1) - 1] + 1 }
    }

    /// Where `path` is written (its key, or for array elements the element itself).
    pub fn key_span(&self, path: &str) -> Option<Range<usize>> {
        self.index.get(path).map(|&i| self.entries[i].1.clone())
    }

    /// Where `path` or its nearest written ancestor is (a defaulted key has no position of its
    /// own; its table's header is the best place to point at).
    pub fn nearest_span(&self, path: &str) -> Option<Range<usize>> {
        let mut p = path.to_string();
        loop {
            if let Some(s) = self.key_span(&p) {
                return Some(s);
            }
            let cut = p.rfind(['.', '['])?;
            p.truncate(cut);
        }
    }

    /// The innermost key whose value contains `offset`.
    pub fn path_at(&self, offset: usize) -> Option<&str> {
        self.entries
            .iter()
            .filter(|(_, k, v)| k.contains(&offset) || v.contains(&offset) || v.end == offset)
            .min_by_key(|(_, k, v)| v.end.max(k.end) - k.start.min(v.start))
            .map(|(p, ..)| p.as_str())
    }
}

/// A problem in TOML text: where (1-based line/column, 0 when unknown), which key, and what.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceError {
    pub line: usize,
    pub column: usize,
    pub key: String,
    pub message: String,
}

impl SourceError {
    /// An error about `key`, placed at the key (or its nearest written ancestor).
    pub fn at_key(loc: &Locator, key: &str, message: impl Into<String>) -> Self {
        let lc = loc.nearest_span(key).map(|s| loc.line_col(s.start));
        Self {
            line: lc.map_or(0, |l| l.line),
            column: lc.map_or(0, |l| l.column),
            key: key.to_string(),
            message: message.into(),
        }
    }

    /// A serde/TOML error, placed at its span and named by the key enclosing that span.
    pub fn from_toml(loc: &Locator, err: &toml::de::Error) -> Self {
        let message = err.message().trim().to_string();
        match err.span() {
            Some(span) => {
                // The enclosing key; for a missing field, the table it belongs in.
                let mut key = loc.path_at(span.start).unwrap_or("").to_string();
                let mut offset = span.start;
                // Serde sometimes places an unknown field at its whole table (internally tagged
                // enums buffer their content): point at the field itself when the table has it.
                if let Some(field) =
                    message.strip_prefix("unknown field `").and_then(|m| m.split('`').next())
                {
                    let candidate = join_key(&key, field);
                    if !key.ends_with(&format!(".{field}"))
                        && key != field
                        && let Some(s) = loc.key_span(&candidate)
                    {
                        key = candidate;
                        offset = s.start;
                    }
                }
                let lc = loc.line_col(offset);
                // toml says only "duplicate key": name it, from the line it points at
                let mut message = message;
                if message == "duplicate key"
                    && let Some(name) = loc
                        .lines
                        .get(lc.line.saturating_sub(1))
                        .and_then(|l| l.split('=').next())
                        .map(|k| k.trim().trim_matches('"').to_string())
                        .filter(|k| !k.is_empty())
                {
                    message = format!("duplicate key `{name}`: it is set twice");
                    key = join_key(&key, &name);
                }
                Self { line: lc.line, column: lc.column, key, message }
            }
            None => Self { line: 0, column: 0, key: String::new(), message },
        }
    }
}

impl std::fmt::Display for SourceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line > 0 {
            write!(f, "line {}, column {}: ", self.line, self.column)?;
        }
        if !self.key.is_empty() {
            write!(f, "key `{}`: ", self.key)?;
        }
        f.write_str(&self.message)
    }
}

/// Joins a key to a path the way [`Locator`] names paths: keys that are not bare are quoted.
pub fn join_key(prefix: &str, key: &str) -> String {
    let key = if !key.is_empty()
        && key.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        key.to_string()
    } else {
        format!("\"{key}\"")
    };
    if prefix.is_empty() { key } else { format!("{prefix}.{key}") }
}

fn walk_table(
    table: &DeTable<'_>,
    prefix: &str,
    out: &mut Vec<(String, Range<usize>, Range<usize>)>,
) {
    for (key, value) in table {
        let path = join_key(prefix, key.get_ref());
        out.push((path.clone(), key.span(), value.span()));
        walk_value(value.get_ref(), &path, out);
    }
}

fn walk_value(
    value: &DeValue<'_>,
    path: &str,
    out: &mut Vec<(String, Range<usize>, Range<usize>)>,
) {
    match value {
        DeValue::Table(t) => walk_table(t, path, out),
        DeValue::Array(items) => {
            for (i, item) in items.iter().enumerate() {
                let p = format!("{path}[{i}]");
                out.push((p.clone(), item.span(), item.span()));
                walk_value(item.get_ref(), &p, out);
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DOC: &str = "id = \"x\"\n\n[base.laser]\nmax_range_m = 8.0\n\n[[sweeps]]\nvalues = { \"odometry.k\" = [0.1, -2.0] }\n";

    #[test]
    fn finds_keys_tables_and_array_elements() {
        let loc = Locator::new(DOC);
        let at = |p: &str| loc.line_col(loc.key_span(p).unwrap().start);
        assert_eq!(at("id"), LineCol { line: 1, column: 1 });
        assert_eq!(at("base.laser.max_range_m"), LineCol { line: 4, column: 1 });
        assert_eq!(at("sweeps[0].values.\"odometry.k\"[1]").line, 7);
        assert_eq!(at("sweeps[0].values.\"odometry.k\"[1]").column, 33);
    }

    #[test]
    fn nearest_span_falls_back_to_the_table() {
        let loc = Locator::new(DOC);
        let s = loc.nearest_span("base.laser.fov_deg").unwrap();
        assert_eq!(loc.line_col(s.start).line, 3);
    }

    #[test]
    fn path_at_offset_is_innermost() {
        let loc = Locator::new(DOC);
        let off = DOC.find("-2.0").unwrap();
        assert_eq!(loc.path_at(off), Some("sweeps[0].values.\"odometry.k\"[1]"));
    }
}
