//! Typed errors of the core crate, split by whose fault they are.

use thiserror::Error;

/// Every error the core crate returns.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FoveaError {
    /// A parameter is outside its valid range. The message names the parameter, the value given
    /// and the range that would be accepted, so the caller can fix it without reading the source.
    #[error(
        "invalid parameter `{}` = {}: expected {}",
        echoed(.name),
        echoed(.value),
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
/// The errors' `Display` applies it to every field (and [`echoed`] also cuts the fields that
/// quote input).
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

/// How many characters of a user's input an error message quotes before cutting it short
/// ([`shorten`]): enough to recognise a header or a value, short enough for one line.
pub const ECHO_CHARS: usize = 200;

/// `text` cut to its first `max_chars` characters with `…` and the number of characters left
/// out, e.g. a 10,000-column CSV header quoted in an error; `text` itself when it is short
/// enough.
pub fn shorten(text: &str, max_chars: usize) -> std::borrow::Cow<'_, str> {
    match text.char_indices().nth(max_chars) {
        None => std::borrow::Cow::Borrowed(text),
        Some((cut, _)) => {
            let left = text[cut..].chars().count();
            std::borrow::Cow::Owned(format!("{}… ({left} more characters)", &text[..cut]))
        }
    }
}

/// Text quoted from the user's input in a message: [`shorten`]ed to [`ECHO_CHARS`], then
/// [`printable`]. The `InvalidParameter` errors show their name and value this way.
pub fn echoed(text: &str) -> String {
    printable(&shorten(text, ECHO_CHARS)).into_owned()
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_input_is_cut_with_the_count_of_what_was_left_out() {
        assert_eq!(shorten("short", 10), "short");
        assert_eq!(shorten("exactly10!", 10), "exactly10!");
        assert_eq!(
            shorten("abcdefghijkl", 10),
            "abcdefghij… (2 more characters)"
        );
        // Characters, not bytes: a cut never splits one.
        assert_eq!(shorten("ééééé", 2), "éé… (3 more characters)");
        let header = (0..10_000)
            .map(|i| format!("c{i}"))
            .collect::<Vec<_>>()
            .join(",");
        let e = FoveaError::invalid("gaze CSV header", &header, "a time column");
        let text = e.to_string();
        assert!(text.len() < 300, "{} bytes: {text}", text.len());
        assert!(
            text.starts_with("invalid parameter `gaze CSV header` = c0,c1,c2,"),
            "{text}"
        );
        let left = header.chars().count() - ECHO_CHARS;
        assert!(text.ends_with(&format!(
            "… ({left} more characters): expected a time column"
        )));
        // Control characters are still escaped after the cut.
        assert_eq!(echoed("a\nb"), "a\\nb");
    }
}
