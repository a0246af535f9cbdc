//! Range checks shared by every config struct. A config struct mirrors its TOML table one-to-one;
//! its `validate` reports each bad value as a [`Violation`] naming the key relative to that table,
//! and the caller prefixes the table path and turns it into a file/line/key error.

/// One invalid value: the key (relative, dotted) and what is wrong with it.
#[derive(Debug, Clone, PartialEq)]
pub struct Violation {
    pub key: String,
    pub message: String,
}

impl Violation {
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self { key: key.into(), message: message.into() }
    }

    /// The same violation seen from the parent table `prefix`.
    pub fn under(self, prefix: &str) -> Self {
        let key =
            if self.key.is_empty() { prefix.to_string() } else { format!("{prefix}.{}", self.key) };
        Self { key, message: self.message }
    }
}

/// Collects violations while a struct checks its fields.
#[derive(Debug, Default)]
pub struct Checks {
    pub violations: Vec<Violation>,
}

impl Checks {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn fail(&mut self, key: &str, message: impl Into<String>) {
        self.violations.push(Violation::new(key, message));
    }

    pub fn require(&mut self, ok: bool, key: &str, message: impl FnOnce() -> String) {
        if !ok {
            self.fail(key, message());
        }
    }

    pub fn finite(&mut self, key: &str, v: f64) -> bool {
        self.require(v.is_finite(), key, || format!("must be a finite number, got {v}"));
        v.is_finite()
    }

    pub fn non_negative(&mut self, key: &str, v: f64) {
        if self.finite(key, v) {
            self.require(v >= 0.0, key, || format!("must be ≥ 0, got {v}"));
        }
    }

    pub fn positive(&mut self, key: &str, v: f64) {
        if self.finite(key, v) {
            self.require(v > 0.0, key, || format!("must be > 0, got {v}"));
        }
    }

    pub fn in_range(&mut self, key: &str, v: f64, lo: f64, hi: f64) {
        if self.finite(key, v) {
            self.require((lo..=hi).contains(&v), key, || {
                format!("must be in [{lo}, {hi}], got {v}")
            });
        }
    }

    /// Merges the violations of a nested table.
    pub fn nested(&mut self, prefix: &str, violations: Vec<Violation>) {
        self.violations.extend(violations.into_iter().map(|v| v.under(prefix)));
    }

    pub fn finish(self) -> Vec<Violation> {
        self.violations
    }
}
