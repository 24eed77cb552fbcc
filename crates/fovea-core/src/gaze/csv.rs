//! Reading gaze trajectories from eye-tracker CSV exports.
//!
//! # Format
//!
//! Plain text, one sample per row, a **header row required**. Fields are separated by commas,
//! semicolons or tabs (detected from the header: tab if it has one, else `;` if it has one,
//! else `,`; or forced with [`CsvOptions::delimiter`]). With `;` or tab separators a decimal
//! comma (`0,5`) is accepted too. Lines whose first non-blank character is `#` and blank lines
//! are skipped anywhere; a UTF-8 byte-order mark is ignored. Fields may be wrapped in double
//! quotes, but a quoted field may not contain the separator. Extra columns are ignored, so the
//! Pupil Labs `gaze_positions.csv` export (`gaze_timestamp, world_index, confidence,
//! norm_pos_x, norm_pos_y, …`) reads as is.
//!
//! Columns are matched by name, case-insensitively, after trimming; the first column carrying
//! an accepted name wins:
//!
//! | role | accepted names | unit |
//! |---|---|---|
//! | time (required) | `t`, `time`, `timestamp`, `gaze_timestamp`, `t_s`, `time_s`, `timestamp_s` | s |
//! | | `t_ms`, `time_ms`, `timestamp_ms` | ms |
//! | | `t_us`, `time_us`, `timestamp_us`, `device_time_stamp` | µs |
//! | | `t_ns`, `time_ns`, `timestamp_ns` | ns |
//! | gaze x, y in pixels | `x`/`y`, `gaze_x`/`gaze_y`, `x_px`/`y_px`, `gaze_x_px`/`gaze_y_px` | px, y down |
//! | gaze x, y normalised | `x_norm`/`y_norm`, `gaze_x_norm`/`gaze_y_norm`, `norm_x`/`norm_y`, `norm_pos_x`/`norm_pos_y` | 0–1 of the screen |
//! | gaze depth (optional) | `depth`, `depth_m`, `gaze_depth`, `gaze_depth_m`; `depth_mm`, `gaze_depth_mm` | m; mm |
//! | right eye (optional) | `right_x`/`right_y` (px) or `right_x_norm`/`right_y_norm` | as gaze |
//! | confidence (optional) | `confidence`, `conf` | 0–1 |
//!
//! A bare time name (`t`, `time`, `timestamp`) is in seconds unless [`CsvOptions::time_unit`]
//! says otherwise; a `Some` there overrides every suffix. Pixel columns win over normalised ones
//! when a file has both. Normalised coordinates map 0 → left/top edge and 1 → right/bottom edge
//! (`x_px = x_n·W`), except that **Pupil Labs `norm_pos_y` is bottom-up** (0 = bottom), so
//! `y_px = (1 − y_n)·H` for it: [`CsvOptions::normalised_y_up`] is `None` by default, meaning
//! "y up exactly when the y column is `norm_pos_y`", and `Some(b)` forces it either way. By
//! default times are rebased so the first row is at `t = 0` ([`CsvOptions::rebase_time`]).
//!
//! # Bad-input policy
//!
//! * Missing header, or no time / x / y column: error listing the columns found and the names
//!   accepted.
//! * A time cell that is empty or not a finite number: error with the line number (a sample
//!   cannot be placed without its time).
//! * Timestamps must strictly increase: a row whose time is **equal to or earlier than** the
//!   previous row's is an error naming both line numbers (no silent merging or sorting).
//! * A **gap** — empty, NaN or non-numeric gaze x/y, a confidence below
//!   [`CsvOptions::min_confidence`] (default 0.6, Pupil Labs' own threshold) or not a number, or
//!   a gaze off the screen by more than [`OFFSCREEN_MARGIN_FRACTION`] (5 %) of its size — is
//!   handled by [`CsvOptions::gap_policy`]: [`GapPolicy::HoldLast`] (default) keeps the row
//!   with `valid = false` and the last valid gaze (leading gaps take the first valid gaze);
//!   [`GapPolicy::Drop`] leaves the row out, so interpolation bridges the gap;
//!   [`GapPolicy::Error`] fails with the line number and the reason.
//! * A gaze off the screen by no more than the margin is clamped onto the screen and counted.
//! * Depth that is empty, not finite or ≤ 0 becomes `None`; a right-eye gaze that is missing or
//!   beyond the margin holds the last valid right-eye gaze (or `None`); within the margin it is
//!   clamped. Neither makes the row a gap: validity is the first eye's.
//! * No data row, or no valid sample at all: error.
//! * More than [`CsvOptions::max_rows`] data rows (default 10 million): a
//!   [`FoveaError::ResourceLimit`] error, raised before the rest is stored.
//!
//! Nothing in this module panics, whatever the input text.

use crate::error::{FoveaError, Result};

use super::{GazeSample, GazeTrajectory, MAX_SAMPLES};

/// How far (as a fraction of the screen width/height) a gaze may lie off the screen and still
/// be clamped onto it; beyond that it is a tracking failure, handled like a blink. Same value as
/// [`crate::display::GAZE_MARGIN_FRACTION`].
pub const OFFSCREEN_MARGIN_FRACTION: f64 = crate::display::GAZE_MARGIN_FRACTION;

/// Unit of the time column.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeUnit {
    /// Seconds.
    Seconds,
    /// Milliseconds.
    Milliseconds,
    /// Microseconds.
    Microseconds,
    /// Nanoseconds.
    Nanoseconds,
}

impl TimeUnit {
    /// Seconds per unit.
    pub fn seconds(self) -> f64 {
        match self {
            TimeUnit::Seconds => 1.0,
            TimeUnit::Milliseconds => 1e-3,
            TimeUnit::Microseconds => 1e-6,
            TimeUnit::Nanoseconds => 1e-9,
        }
    }
}

/// What to do with a blink or tracking gap (see the module's policy list).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum GapPolicy {
    /// Keep the row, marked invalid, at the last valid gaze.
    #[default]
    HoldLast,
    /// Leave the row out.
    Drop,
    /// Fail with the line number.
    Error,
}

/// Options of [`parse_csv`]. `Default` gives the documented defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct CsvOptions {
    /// Force the time unit; `None` reads it from the column name (bare names: seconds).
    pub time_unit: Option<TimeUnit>,
    /// Force whether normalised y grows upwards; `None`: only for `norm_pos_y`.
    pub normalised_y_up: Option<bool>,
    /// Rows with a confidence below this (in [0, 1]) are gaps. Default 0.6.
    pub min_confidence: f64,
    /// Blink/gap policy. Default [`GapPolicy::HoldLast`].
    pub gap_policy: GapPolicy,
    /// Force the field separator; `None` detects it from the header.
    pub delimiter: Option<char>,
    /// Shift times so the first row is at 0. Default `true`.
    pub rebase_time: bool,
    /// Most data rows accepted. Default (and maximum) 10 million.
    pub max_rows: usize,
}

impl Default for CsvOptions {
    fn default() -> Self {
        CsvOptions {
            time_unit: None,
            normalised_y_up: None,
            min_confidence: 0.6,
            gap_policy: GapPolicy::HoldLast,
            delimiter: None,
            rebase_time: true,
            max_rows: MAX_SAMPLES,
        }
    }
}

/// What [`parse_csv`] found and did.
#[derive(Clone, Debug, PartialEq)]
pub struct CsvReport {
    /// Data rows read (excluding header, comments, blank lines).
    pub rows: usize,
    /// Rows with a valid gaze.
    pub valid: usize,
    /// Gap rows kept at the last valid gaze ([`GapPolicy::HoldLast`]).
    pub held: usize,
    /// Gap rows left out ([`GapPolicy::Drop`]).
    pub dropped: usize,
    /// Gazes (first eye) clamped onto the screen from within the margin.
    pub clamped: usize,
    /// Gaps caused by a confidence below the threshold.
    pub low_confidence: usize,
    /// Gaps caused by a gaze beyond the off-screen margin.
    pub off_screen: usize,
    /// The separator used.
    pub delimiter: char,
    /// Header name of the time column, and its unit.
    pub time_column: String,
    /// Unit applied to the time column.
    pub time_unit: TimeUnit,
    /// Header names of the x and y columns.
    pub xy_columns: (String, String),
    /// Whether x/y were normalised (0–1) rather than pixels.
    pub normalised: bool,
    /// Whether normalised y was read bottom-up.
    pub y_up: bool,
    /// Time subtracted from every row (the first row's, in seconds) when rebasing, else 0.
    pub time_offset_s: f64,
}

const TIME_S: &[&str] = &[
    "t",
    "time",
    "timestamp",
    "gaze_timestamp",
    "t_s",
    "time_s",
    "timestamp_s",
];
const TIME_MS: &[&str] = &["t_ms", "time_ms", "timestamp_ms"];
const TIME_US: &[&str] = &["t_us", "time_us", "timestamp_us", "device_time_stamp"];
const TIME_NS: &[&str] = &["t_ns", "time_ns", "timestamp_ns"];
const X_PX: &[&str] = &["x", "gaze_x", "x_px", "gaze_x_px"];
const Y_PX: &[&str] = &["y", "gaze_y", "y_px", "gaze_y_px"];
const X_NORM: &[&str] = &["x_norm", "gaze_x_norm", "norm_x", "norm_pos_x"];
const Y_NORM: &[&str] = &["y_norm", "gaze_y_norm", "norm_y", "norm_pos_y"];
const DEPTH_M: &[&str] = &["depth", "depth_m", "gaze_depth", "gaze_depth_m"];
const DEPTH_MM: &[&str] = &["depth_mm", "gaze_depth_mm"];
const CONFIDENCE: &[&str] = &["confidence", "conf"];

fn find(header: &[String], names: &[&str]) -> Option<usize> {
    header.iter().position(|h| names.contains(&h.as_str()))
}

fn accepted_names() -> String {
    let j = |a: &[&str]| a.join(", ");
    format!(
        "a time column ({}; ms: {}; µs: {}; ns: {}) and gaze x/y columns in pixels ({} / {}) \
         or normalised ({} / {})",
        j(TIME_S),
        j(TIME_MS),
        j(TIME_US),
        j(TIME_NS),
        j(X_PX),
        j(Y_PX),
        j(X_NORM),
        j(Y_NORM)
    )
}

/// Splits one line into trimmed, unquoted fields.
fn fields(line: &str, delim: char) -> Vec<&str> {
    line.split(delim)
        .map(|f| {
            let f = f.trim();
            let f = f.strip_prefix('"').unwrap_or(f);
            let f = f.strip_suffix('"').unwrap_or(f);
            f.trim()
        })
        .collect()
}

/// Parses a number; `None` for empty, non-numeric or non-finite text.
fn number(cell: &str, decimal_comma: bool) -> Option<f64> {
    let v = if decimal_comma && cell.contains(',') && !cell.contains('.') {
        cell.replace(',', ".").parse::<f64>().ok()?
    } else {
        cell.parse::<f64>().ok()?
    };
    v.is_finite().then_some(v)
}

/// Where a gaze point lies relative to the screen and its margin.
enum Placement {
    On(f64, f64),
    Clamped(f64, f64),
    Off,
}

fn place(x: f64, y: f64, w: f64, h: f64) -> Placement {
    let (mx, my) = (w * OFFSCREEN_MARGIN_FRACTION, h * OFFSCREEN_MARGIN_FRACTION);
    if x < -mx || x > w + mx || y < -my || y > h + my {
        Placement::Off
    } else if (0.0..=w).contains(&x) && (0.0..=h).contains(&y) {
        Placement::On(x, y)
    } else {
        Placement::Clamped(x.clamp(0.0, w), y.clamp(0.0, h))
    }
}

/// Parses an eye-tracker CSV export (format and policies in the module docs) into a trajectory
/// on a `width_px × height_px` screen, with a report of what was held, dropped and clamped.
pub fn parse_csv(
    text: &str,
    width_px: f64,
    height_px: f64,
    opts: &CsvOptions,
) -> Result<(GazeTrajectory, CsvReport)> {
    crate::error::check_range_open_lo("width_px", width_px, 0.0, f64::INFINITY)?;
    crate::error::check_range_open_lo("height_px", height_px, 0.0, f64::INFINITY)?;
    crate::error::check_range("min_confidence", opts.min_confidence, 0.0, 1.0)?;
    if opts.max_rows == 0 || opts.max_rows > MAX_SAMPLES {
        return Err(FoveaError::invalid(
            "max_rows",
            opts.max_rows,
            format!("1 to {MAX_SAMPLES}"),
        ));
    }
    if let Some(d) = opts.delimiter {
        if d == '"' || d == '#' || d == '.' || d == '\n' || d == '\r' || d.is_ascii_digit() {
            return Err(FoveaError::invalid(
                "delimiter",
                format!("{d:?}"),
                "a separator other than a quote, '#', '.', a digit or a newline",
            ));
        }
    }
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
        .filter(|(_, l)| {
            let t = l.trim();
            !t.is_empty() && !t.starts_with('#')
        });

    // Header.
    let Some((header_line, header_text)) = lines.next() else {
        return Err(FoveaError::invalid(
            "gaze CSV header",
            "no header row (the text is empty or only comments)",
            accepted_names(),
        ));
    };
    let delim = opts.delimiter.unwrap_or(if header_text.contains('\t') {
        '\t'
    } else if header_text.contains(';') {
        ';'
    } else {
        ','
    });
    let decimal_comma = delim != ',';
    let header: Vec<String> = fields(header_text, delim)
        .iter()
        .map(|h| h.to_lowercase())
        .collect();
    // Control characters in a header cell (a stray `\r`, a NUL) are escaped when the error
    // is shown (`FoveaError`'s `Display`): the message stays one printable line.
    // A header of thousands of columns is counted, and quoted cut short (the error's
    // `Display` shortens the value: `crate::error::echoed`).
    let found = || match header.len() {
        n if n > 20 => format!("{n} columns [{}]", header.join(", ")),
        _ => format!("columns [{}]", header.join(", ")),
    };
    let missing = |what: &str| {
        FoveaError::invalid(
            format!("gaze CSV header (line {header_line}): missing {what}"),
            found(),
            accepted_names(),
        )
    };

    let time_col;
    let time_unit_named;
    if let Some(i) = find(&header, TIME_S) {
        (time_col, time_unit_named) = (i, TimeUnit::Seconds);
    } else if let Some(i) = find(&header, TIME_MS) {
        (time_col, time_unit_named) = (i, TimeUnit::Milliseconds);
    } else if let Some(i) = find(&header, TIME_US) {
        (time_col, time_unit_named) = (i, TimeUnit::Microseconds);
    } else if let Some(i) = find(&header, TIME_NS) {
        (time_col, time_unit_named) = (i, TimeUnit::Nanoseconds);
    } else {
        return Err(missing("a time column"));
    }
    let time_unit = opts.time_unit.unwrap_or(time_unit_named);
    let (x_col, y_col, normalised) = match (find(&header, X_PX), find(&header, Y_PX)) {
        (Some(x), Some(y)) => (x, y, false),
        _ => match (find(&header, X_NORM), find(&header, Y_NORM)) {
            (Some(x), Some(y)) => (x, y, true),
            _ => return Err(missing("a gaze x/y column pair")),
        },
    };
    let y_up = normalised
        && opts
            .normalised_y_up
            .unwrap_or(header[y_col] == "norm_pos_y");
    let depth_col = find(&header, DEPTH_M)
        .map(|i| (i, 1.0))
        .or_else(|| find(&header, DEPTH_MM).map(|i| (i, 1e-3)));
    let right_cols = match (
        find(&header, &["right_x"]),
        find(&header, &["right_y"]),
        find(&header, &["right_x_norm"]),
        find(&header, &["right_y_norm"]),
    ) {
        (Some(x), Some(y), _, _) => Some((x, y, false)),
        (_, _, Some(x), Some(y)) => Some((x, y, true)),
        _ => None,
    };
    let conf_col = find(&header, CONFIDENCE);

    let to_px = |x: f64, y: f64, norm: bool| -> (f64, f64) {
        if norm {
            let yn = if y_up { 1.0 - y } else { y };
            (x * width_px, yn * height_px)
        } else {
            (x, y)
        }
    };

    let mut report = CsvReport {
        rows: 0,
        valid: 0,
        held: 0,
        dropped: 0,
        clamped: 0,
        low_confidence: 0,
        off_screen: 0,
        delimiter: delim,
        time_column: header[time_col].clone(),
        time_unit,
        xy_columns: (header[x_col].clone(), header[y_col].clone()),
        normalised,
        y_up,
        time_offset_s: 0.0,
    };
    let mut samples: Vec<GazeSample> = Vec::new();
    let mut prev_time: Option<(f64, usize)> = None;
    let mut last_valid: Option<(f64, f64)> = None;
    let mut last_right: Option<(f64, f64)> = None;
    let mut leading_gaps = 0usize;

    for (line_no, line) in lines {
        report.rows += 1;
        if report.rows > opts.max_rows {
            return Err(row_limit(opts.max_rows));
        }
        let f = fields(line, delim);
        let cell = |i: usize| f.get(i).copied().unwrap_or("");
        let col_name = |i: usize| header.get(i).map(String::as_str).unwrap_or("?");

        // Time: required, finite, strictly increasing.
        let raw_t = cell(time_col);
        let Some(t_s) = number(raw_t, decimal_comma)
            .map(|t| t * time_unit.seconds())
            .filter(|t| t.is_finite())
        else {
            return Err(FoveaError::invalid(
                format!("gaze CSV line {line_no}, column {}", col_name(time_col)),
                format!("{raw_t:?}"),
                "a finite number (every row needs a timestamp)",
            ));
        };
        if let Some((pt, pl)) = prev_time {
            if t_s <= pt {
                return Err(FoveaError::invalid(
                    format!("gaze CSV line {line_no}, column {}", col_name(time_col)),
                    raw_t,
                    format!(
                        "a timestamp later than line {pl}'s ({pt} s): timestamps must strictly \
                         increase (equal timestamps are rejected too)"
                    ),
                ));
            }
        }
        prev_time = Some((t_s, line_no));

        // Gaze of the first eye: decide valid / clamped / gap.
        let (rx, ry) = (cell(x_col), cell(y_col));
        let conf = conf_col.map(|c| number(cell(c), decimal_comma));
        let mut gap: Option<String> = None;
        let mut pos = None;
        if let Some(c) = conf {
            if c.is_none_or(|c| c < opts.min_confidence) {
                report.low_confidence += 1;
                gap = Some(format!(
                    "confidence {:?} below min_confidence {}",
                    cell(conf_col.unwrap_or(0)),
                    opts.min_confidence
                ));
            }
        }
        if gap.is_none() {
            match (number(rx, decimal_comma), number(ry, decimal_comma)) {
                (Some(x), Some(y)) => {
                    let (x, y) = to_px(x, y, normalised);
                    match place(x, y, width_px, height_px) {
                        Placement::On(x, y) => pos = Some((x, y)),
                        Placement::Clamped(x, y) => {
                            report.clamped += 1;
                            pos = Some((x, y));
                        }
                        Placement::Off => {
                            report.off_screen += 1;
                            gap = Some(format!(
                                "gaze ({x}, {y}) px lies more than {} % off the {width_px}×{height_px} screen",
                                OFFSCREEN_MARGIN_FRACTION * 100.0
                            ));
                        }
                    }
                }
                _ => {
                    gap = Some(format!(
                        "gaze x/y ({rx:?}, {ry:?}) is empty, NaN or not a number (a blink?)"
                    ))
                }
            }
        }

        // Optional channels.
        let depth_m = depth_col
            .and_then(|(i, scale)| number(cell(i), decimal_comma).map(|d| d * scale))
            .filter(|d| d.is_finite() && *d > 0.0);
        if let Some((xi, yi, norm)) = right_cols {
            if let (Some(x), Some(y)) = (
                number(cell(xi), decimal_comma),
                number(cell(yi), decimal_comma),
            ) {
                let (x, y) = to_px(x, y, norm);
                match place(x, y, width_px, height_px) {
                    Placement::On(x, y) | Placement::Clamped(x, y) => last_right = Some((x, y)),
                    Placement::Off => {}
                }
            }
        }

        match (pos, gap) {
            (Some((x, y)), _) => {
                report.valid += 1;
                last_valid = Some((x, y));
                samples.push(GazeSample {
                    t_s,
                    x_px: x,
                    y_px: y,
                    depth_m,
                    right: last_right,
                    valid: true,
                });
            }
            (None, gap) => {
                let reason = gap.unwrap_or_default();
                match opts.gap_policy {
                    GapPolicy::Error => {
                        return Err(FoveaError::invalid(
                            format!("gaze CSV line {line_no}, columns {}/{}", col_name(x_col), col_name(y_col)),
                            reason,
                            "a valid gaze on every row (gap_policy = Error; use HoldLast or Drop to accept blinks)",
                        ))
                    }
                    GapPolicy::Drop => report.dropped += 1,
                    GapPolicy::HoldLast => {
                        report.held += 1;
                        let (x, y) = last_valid.unwrap_or((f64::NAN, f64::NAN));
                        if last_valid.is_none() {
                            leading_gaps += 1;
                        }
                        samples.push(GazeSample {
                            t_s,
                            x_px: x,
                            y_px: y,
                            depth_m,
                            right: last_right,
                            valid: false,
                        });
                    }
                }
            }
        }
    }

    if report.rows == 0 {
        return Err(FoveaError::invalid(
            "gaze CSV",
            "a header but no data rows",
            "at least one data row after the header",
        ));
    }
    let Some(first_valid) = samples.iter().find(|s| s.valid).map(|s| (s.x_px, s.y_px)) else {
        return Err(FoveaError::invalid(
            "gaze CSV",
            format!("{} rows, none with a valid gaze", report.rows),
            format!(
                "at least one row with a numeric on-screen gaze and confidence ≥ {}",
                opts.min_confidence
            ),
        ));
    };
    // Leading gaps (before any valid gaze) take the first valid gaze.
    for s in samples.iter_mut().take(leading_gaps) {
        (s.x_px, s.y_px) = first_valid;
    }
    if opts.rebase_time {
        report.time_offset_s = samples[0].t_s;
        let t0 = report.time_offset_s;
        for s in &mut samples {
            s.t_s -= t0;
        }
        // Rebasing can round two distinct huge timestamps (e.g. ns since 1970) together.
        if samples.windows(2).any(|w| w[1].t_s <= w[0].t_s) {
            return Err(FoveaError::invalid(
                "gaze CSV timestamps",
                format!("offset {t0} s"),
                "timestamps that stay distinct in f64 seconds",
            ));
        }
    }
    let traj = GazeTrajectory::new(samples, width_px, height_px)?;
    Ok((traj, report))
}

/// Counts the data rows of a gaze CSV read from `reader` one line at a time (memory: the
/// longest line), the rows [`parse_csv`] counts (after the header; blank lines and `#`
/// comments skipped), and refuses more than `max_rows` as soon as the count passes it, with
/// the error [`parse_csv`] gives. Run it on a file before reading the file's text, so a
/// recording of 10 million rows is refused without holding it (issue 39).
pub fn check_row_count<R: std::io::BufRead>(mut reader: R, max_rows: usize) -> Result<usize> {
    let mut line = Vec::new();
    let mut rows = 0usize;
    let mut header_seen = false;
    let mut first = true;
    loop {
        line.clear();
        let n = reader.read_until(b'\n', &mut line).map_err(|e| {
            FoveaError::invalid(
                "gaze CSV",
                format!("unreadable: {e}"),
                "a readable text file",
            )
        })?;
        if n == 0 {
            break;
        }
        let mut l: &[u8] = &line;
        if first {
            l = l.strip_prefix("\u{feff}".as_bytes()).unwrap_or(l);
            first = false;
        }
        let t = l.trim_ascii();
        if t.is_empty() || t.starts_with(b"#") {
            continue;
        }
        if !header_seen {
            header_seen = true;
            continue;
        }
        rows += 1;
        if rows > max_rows {
            return Err(row_limit(max_rows));
        }
    }
    Ok(rows)
}

/// The error for more than `max_rows` data rows.
fn row_limit(max_rows: usize) -> FoveaError {
    FoveaError::ResourceLimit {
        what: "gaze CSV".into(),
        needed: format!("more than {max_rows} data rows"),
        limit: format!("{max_rows} rows (split the recording)"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const W: f64 = 1000.0;
    const H: f64 = 500.0;

    fn parse(text: &str) -> Result<(GazeTrajectory, CsvReport)> {
        parse_csv(text, W, H, &CsvOptions::default())
    }

    fn err_text(text: &str, opts: &CsvOptions) -> String {
        parse_csv(text, W, H, opts).unwrap_err().to_string()
    }

    #[test]
    fn pixels_seconds_commas() {
        let (t, r) = parse("# recorded\nt,x,y\n0.5,100,200\n\n0.6,110,210\n").unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!(r.time_offset_s, 0.5);
        let s = t.samples();
        assert_eq!((s[0].t_s, s[0].x_px, s[0].y_px), (0.0, 100.0, 200.0));
        assert!((s[1].t_s - 0.1).abs() < 1e-12);
        assert!(!r.normalised && r.delimiter == ',' && r.time_unit == TimeUnit::Seconds);
        assert_eq!((r.rows, r.valid, r.held, r.clamped), (2, 2, 0, 0));
        assert!((t.at(0.05).x_px - 105.0).abs() < 1e-9);
    }

    #[test]
    fn normalised_y_down_and_ms() {
        let (t, r) =
            parse("Time_ms,Gaze_X_Norm,Gaze_Y_Norm,depth\n10,0.5,0.25,2.0\n20,0.1,0.9,\n").unwrap();
        assert!(r.normalised && !r.y_up && r.time_unit == TimeUnit::Milliseconds);
        let s = t.samples();
        assert_eq!((s[0].x_px, s[0].y_px), (500.0, 125.0));
        assert_eq!(s[0].depth_m, Some(2.0));
        assert_eq!(s[1].depth_m, None);
        assert!((s[1].t_s - 0.010).abs() < 1e-12);
        assert!((s[1].y_px - 450.0).abs() < 1e-9);
    }

    #[test]
    fn pupil_labs_layout() {
        let text = "gaze_timestamp,world_index,confidence,norm_pos_x,norm_pos_y,base_data,gaze_point_3d_x\n\
                    5012.10,0,0.99,0.5,0.75,5012.09-0 5012.10-1,12.0\n\
                    5012.11,0,0.95,0.25,0.0,5012.10-0,13.0\n\
                    5012.12,1,0.20,0.9,0.9,5012.11-1,13.0\n\
                    5012.13,1,0.97,0.4,0.5,5012.12-1,13.0\n";
        let (t, r) = parse(text).unwrap();
        assert!(r.y_up && r.normalised);
        assert_eq!(
            r.xy_columns,
            ("norm_pos_x".to_string(), "norm_pos_y".to_string())
        );
        let s = t.samples();
        assert_eq!(s.len(), 4);
        assert_eq!((s[0].x_px, s[0].y_px), (500.0, 125.0)); // 0.75 up → 0.25 down
        assert_eq!((s[1].x_px, s[1].y_px), (250.0, 500.0)); // bottom edge
        assert!(!s[2].valid);
        assert_eq!((s[2].x_px, s[2].y_px), (250.0, 500.0)); // held
        assert_eq!((r.held, r.low_confidence, r.valid), (1, 1, 3));
        assert!((s[3].t_s - 0.03).abs() < 1e-9);
        // Forcing y down.
        let opts = CsvOptions {
            normalised_y_up: Some(false),
            ..Default::default()
        };
        let (t, _) = parse_csv(text, W, H, &opts).unwrap();
        assert_eq!(t.samples()[0].y_px, 375.0);
    }

    #[test]
    fn semicolons_tabs_decimal_commas_us_and_second_eye() {
        let (t, r) =
            parse("timestamp_us;x_px;y_px;right_x;right_y\n1000;1,5;2,5;10;20\n2000;3;4;;\n")
                .unwrap();
        assert_eq!(r.delimiter, ';');
        let s = t.samples();
        assert_eq!((s[0].x_px, s[0].y_px), (1.5, 2.5));
        assert_eq!(s[0].right, Some((10.0, 20.0)));
        assert_eq!(s[1].right, Some((10.0, 20.0))); // held
        assert!((s[1].t_s - 0.001).abs() < 1e-15);
        let (t, r) = parse("\u{feff}t\tx\ty\n0\t1\t2\n1\t3\t4\n").unwrap();
        assert_eq!(r.delimiter, '\t');
        assert_eq!(t.samples()[1].x_px, 3.0);
        // Forced unit overrides the suffix; quoted fields; CRLF.
        let opts = CsvOptions {
            time_unit: Some(TimeUnit::Milliseconds),
            ..Default::default()
        };
        let (t, _) = parse_csv("\"t\",\"x\",\"y\"\r\n0,1,1\r\n5,2,2\r\n", W, H, &opts).unwrap();
        assert!((t.samples()[1].t_s - 0.005).abs() < 1e-15);
    }

    #[test]
    fn missing_columns_name_what_was_found() {
        let e = err_text("t,gaze_x\n0,1\n", &CsvOptions::default());
        assert!(e.contains("missing a gaze x/y column pair"), "{e}");
        assert!(e.contains("[t, gaze_x]") && e.contains("norm_pos_y"), "{e}");
        let e = err_text("a,x,y\n0,1,2\n", &CsvOptions::default());
        assert!(
            e.contains("missing a time column") && e.contains("timestamp_us"),
            "{e}"
        );
        assert!(err_text("", &CsvOptions::default()).contains("no header"));
        assert!(err_text("# only\n\n", &CsvOptions::default()).contains("no header"));
        assert!(err_text("t,x,y\n", &CsvOptions::default()).contains("no data rows"));
        // Found by fuzzing: a CR or NUL inside a header cell was echoed raw, breaking the
        // one-line message; now shown escaped.
        let e = err_text("time;gaze_x;r\r\0_x\n0;1;2\n", &CsvOptions::default());
        assert!(e.contains("[time, gaze_x, r\\r\\u{0}_x]"), "{e}");
        assert!(!e.contains('\r') && !e.contains('\0'), "{e}");
    }

    #[test]
    fn timestamps_must_strictly_increase() {
        let e = err_text("t,x,y\n0,1,1\n2,1,1\n1,1,1\n", &CsvOptions::default());
        assert!(e.contains("line 4") && e.contains("line 3"), "{e}");
        let e = err_text("t,x,y\n0,1,1\n0,1,1\n", &CsvOptions::default());
        assert!(e.contains("line 3") && e.contains("equal"), "{e}");
        let e = err_text("t,x,y\n0,1,1\nNaN,1,1\n", &CsvOptions::default());
        assert!(e.contains("line 3, column t"), "{e}");
        let e = err_text("t,x,y\n0,1,1\n,1,1\n", &CsvOptions::default());
        assert!(e.contains("line 3"), "{e}");
    }

    #[test]
    fn blinks_hold_last_drop_or_error() {
        let text = "t,x,y\n0,,\n1,100,100\n2,NaN,100\n3,abc,1\n4,200,200\n5\n";
        let (t, r) = parse(text).unwrap();
        let s = t.samples();
        assert_eq!(s.len(), 6);
        assert_eq!((r.held, r.valid), (4, 2));
        // Leading gap takes the first valid gaze; later gaps hold the last valid one.
        assert_eq!((s[0].x_px, s[0].valid), (100.0, false));
        assert_eq!((s[2].x_px, s[3].x_px, s[5].x_px), (100.0, 100.0, 200.0));
        assert!(s[1].valid && s[4].valid && !s[5].valid);
        let drop = CsvOptions {
            gap_policy: GapPolicy::Drop,
            ..Default::default()
        };
        let (t, r) = parse_csv(text, W, H, &drop).unwrap();
        assert_eq!((t.len(), r.dropped), (2, 4));
        assert_eq!(t.start_s(), 0.0); // rebased on the first kept row
        assert!((t.at(1.5).x_px - 150.0).abs() < 1e-9); // bridged by interpolation
        let strict = CsvOptions {
            gap_policy: GapPolicy::Error,
            ..Default::default()
        };
        let e = err_text(text, &strict);
        assert!(e.contains("line 2") && e.contains("blink"), "{e}");
        let e = err_text("t,x,y\n0,,\n1,,\n", &CsvOptions::default());
        assert!(e.contains("none with a valid gaze"), "{e}");
    }

    #[test]
    fn off_screen_clamped_within_margin_gap_beyond() {
        // Margin: 50 px in x, 25 px in y.
        let text = "t,x,y\n0,500,250\n1,-40,250\n2,1049,520\n3,-51,250\n4,500,526\n5,1e300,1\n";
        let (t, r) = parse(text).unwrap();
        let s = t.samples();
        assert_eq!((r.clamped, r.off_screen, r.held), (2, 3, 3));
        assert_eq!((s[1].x_px, s[1].y_px), (0.0, 250.0));
        assert_eq!((s[2].x_px, s[2].y_px), (1000.0, 500.0));
        assert!(s[1].valid && s[2].valid);
        assert!(!s[3].valid && s[3].x_px == 1000.0 && s[3].y_px == 500.0);
        assert!(!s[4].valid && !s[5].valid);
        let e = err_text(
            text,
            &CsvOptions {
                gap_policy: GapPolicy::Error,
                ..Default::default()
            },
        );
        assert!(e.contains("line 5") && e.contains("off the"), "{e}");
    }

    #[test]
    fn confidence_threshold_and_options() {
        let text = "t,x,y,confidence\n0,1,1,0.6\n1,2,2,0.59\n2,3,3,\n";
        let (t, r) = parse(text).unwrap();
        assert_eq!((r.valid, r.low_confidence), (1, 2));
        assert!(t.samples()[0].valid && !t.samples()[1].valid);
        let lax = CsvOptions {
            min_confidence: 0.0,
            ..Default::default()
        };
        assert_eq!(parse_csv(text, W, H, &lax).unwrap().1.low_confidence, 1);
        let bad = CsvOptions {
            min_confidence: 1.5,
            ..Default::default()
        };
        assert!(parse_csv(text, W, H, &bad).is_err());
        assert!(parse_csv(text, 0.0, H, &CsvOptions::default()).is_err());
        let keep = CsvOptions {
            rebase_time: false,
            ..Default::default()
        };
        let (t, _) = parse_csv("t,x,y\n7,1,1\n", W, H, &keep).unwrap();
        assert_eq!(t.start_s(), 7.0);
        let forced = CsvOptions {
            delimiter: Some('|'),
            ..Default::default()
        };
        let (t, _) = parse_csv("t|x|y\n0|4|5\n", W, H, &forced).unwrap();
        assert_eq!(t.samples()[0].x_px, 4.0);
        let quote = CsvOptions {
            delimiter: Some('"'),
            ..Default::default()
        };
        assert!(parse_csv("t,x,y\n0,4,5\n", W, H, &quote).is_err());
    }

    #[test]
    fn rows_are_counted_like_parse_csv_and_refused_while_reading() {
        let text = "\u{feff}# c\nt,x,y\n\n0,1,1\n# c\n1,2,2\r\n2,3,3\n";
        assert_eq!(check_row_count(text.as_bytes(), 3).unwrap(), 3);
        assert_eq!(parse(text).unwrap().1.rows, 3);
        let e = check_row_count(text.as_bytes(), 2).unwrap_err();
        assert!(matches!(e, FoveaError::ResourceLimit { .. }), "{e}");
        // Blank lines are not rows, however many.
        let blanks = std::io::Read::chain(
            "t,x,y\n".as_bytes(),
            std::io::Read::take(std::io::repeat(b'\n'), 1 << 20),
        );
        assert_eq!(
            check_row_count(std::io::BufReader::new(blanks), 1).unwrap(),
            0
        );
    }

    #[test]
    fn row_limit_is_a_resource_error() {
        let opts = CsvOptions {
            max_rows: 3,
            ..Default::default()
        };
        let ok = "t,x,y\n0,1,1\n1,1,1\n2,1,1\n";
        assert!(parse_csv(ok, W, H, &opts).is_ok());
        let e = parse_csv(&format!("{ok}3,1,1\n"), W, H, &opts).unwrap_err();
        assert!(matches!(e, FoveaError::ResourceLimit { .. }), "{e}");
        let too_many = CsvOptions {
            max_rows: MAX_SAMPLES + 1,
            ..Default::default()
        };
        assert!(parse_csv(ok, W, H, &too_many).is_err());
    }

    #[test]
    fn huge_timestamps_in_ns_stay_distinct() {
        let (t, r) =
            parse("timestamp_ns,x,y\n1700000000000000000,1,1\n1700000000001000000,2,2\n").unwrap();
        assert_eq!(r.time_unit, TimeUnit::Nanoseconds);
        assert!((t.samples()[1].t_s - 0.001).abs() < 1e-6);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        #[test]
        fn never_panics_on_random_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            let text = String::from_utf8_lossy(&bytes);
            let _ = parse_csv(&text, W, H, &CsvOptions::default());
        }

        #[test]
        fn never_panics_after_a_valid_header(
            header in prop::sample::select(vec![
                "t,x,y", "t;x;y,confidence", "time_ms,norm_pos_x,norm_pos_y,depth,right_x,right_y",
                "gaze_timestamp\tconfidence\tnorm_pos_x\tnorm_pos_y"]),
            body in "[0-9eE.,;\t\n\r#NaInf+ -]{0,300}",
            policy in prop::sample::select(vec![GapPolicy::HoldLast, GapPolicy::Drop, GapPolicy::Error]),
        ) {
            let opts = CsvOptions { gap_policy: policy, ..Default::default() };
            if let Ok((t, r)) = parse_csv(&format!("{header}\n{body}"), W, H, &opts) {
                // Whatever parses is a valid on-screen trajectory.
                prop_assert!(r.valid >= 1);
                for s in t.samples() {
                    prop_assert!((0.0..=W).contains(&s.x_px) && (0.0..=H).contains(&s.y_px));
                }
            }
        }
    }
}
