//! Typed errors of the core crate, split by whose fault they are.

use thiserror::Error;

/// Every error the core crate returns.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FoveaError {
    /// A parameter is outside its valid range. The message names the parameter, the value given
    /// and the range that would be accepted, so the caller can fix it without reading the source.
    #[error(
        "invalid parameter `{}` = {}: expected {}",
        printable(.name),
        printable(.value),
        printable(.expected)
    )]
    InvalidParameter {
        /// Parameter name as the user writes it (CLI flag or struct field).
        name: String,
        /// The offending value, formatted.
        value: String,
        /// The accepted range or form.
        expected: String,
    },
    /// A request that would exceed a resource limit (memory, buffer size), refused before
    /// anything is allocated.
    #[error(
        "resource limit: {} needs {}, but the limit is {}",
        printable(.what),
        printable(.needed),
        printable(.limit)
    )]
    ResourceLimit {
        /// What was requested.
        what: String,
        /// How much it would need.
        needed: String,
        /// The limit in force.
        limit: String,
    },
    /// A feature combination the crate does not support.
    #[error("unsupported: {}", printable(.0))]
    Unsupported(String),
}

/// `text` with its control characters (`\n`, `\r`, NUL, escape…) escaped (`\r`, `\u{0}`):
/// messages quote file contents and names, and every error is shown as one printable line.
/// The errors' `Display` applies it to every field.
pub fn printable(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(char::is_control) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    std::borrow::Cow::Owned(out)
}

/// Result alias of the core crate.
pub type Result<T> = std::result::Result<T, FoveaError>;

impl FoveaError {
    /// Shorthand for [`FoveaError::InvalidParameter`].
    pub fn invalid(
        name: impl Into<String>,
        value: impl std::fmt::Display,
        expected: impl Into<String>,
    ) -> Self {
        FoveaError::InvalidParameter {
            name: name.into(),
            value: value.to_string(),
            expected: expected.into(),
        }
    }
}

/// Checks that `value` is finite and lies in `[lo, hi]` (either bound may be infinite).
pub(crate) fn check_range(name: &str, value: f64, lo: f64, hi: f64) -> Result<f64> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(value)
    } else {
        Err(FoveaError::invalid(name, value, range_text(lo, hi, false)))
    }
}

/// Checks that `value` is finite and lies in `(lo, hi]` (strictly above `lo`).
pub(crate) fn check_range_open_lo(name: &str, value: f64, lo: f64, hi: f64) -> Result<f64> {
    if value.is_finite() && value > lo && value <= hi {
        Ok(value)
    } else {
        Err(FoveaError::invalid(name, value, range_text(lo, hi, true)))
    }
}

fn range_text(lo: f64, hi: f64, open_lo: bool) -> String {
    let l = if open_lo { "(" } else { "[" };
    match (lo.is_finite(), hi.is_finite()) {
        (true, true) => format!("a finite number in {l}{lo}, {hi}]"),
        (true, false) if open_lo => format!("a finite number > {lo}"),
        (true, false) => format!("a finite number ≥ {lo}"),
        (false, true) => format!("a finite number ≤ {hi}"),
        (false, false) => "a finite number".to_string(),
    }
}
