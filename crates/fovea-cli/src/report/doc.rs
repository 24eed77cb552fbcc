//! The report as data: sections of paragraphs, tables, images and checks, written as
//! Markdown, HTML and JSON from the same values, and verified from the JSON.

use std::fmt::Write as _;

use serde::ser::{Serialize, Serializer};
use serde_json::{json, Value};

/// Written where a PSNR is infinite because the images are identical (MSE = 0): the one
/// non-finite value a report may hold, named for what it is.
pub const IDENTICAL: &str = "∞ (identical)";

/// One table cell.
#[derive(Clone, Debug)]
pub enum Cell {
    /// Text (names, labels).
    Text(String),
    /// A count, printed with thousands separators.
    Int(u64),
    /// A measured number, printed with this many decimals.
    Num(f64, usize),
    /// A PSNR in dB (two decimals; +∞ is [`IDENTICAL`]).
    Psnr(f64),
}

impl Cell {
    /// Text cell.
    pub fn text(t: impl Into<String>) -> Self {
        Cell::Text(t.into())
    }

    /// The cell as printed.
    pub fn display(&self) -> String {
        match self {
            Cell::Text(t) => t.clone(),
            Cell::Int(n) => crate::common::thousands(*n),
            Cell::Num(v, d) if v.is_finite() => format!("{v:.d$}"),
            Cell::Psnr(v) if v.is_finite() => format!("{v:.2}"),
            Cell::Psnr(v) if *v == f64::INFINITY => IDENTICAL.into(),
            Cell::Num(v, _) | Cell::Psnr(v) => non_finite(*v).into(),
        }
    }
}

/// How a non-finite number appears in the JSON, so that `--verify` finds it (serde_json would
/// write `null`).
fn non_finite(v: f64) -> &'static str {
    if v.is_nan() {
        "NaN"
    } else if v > 0.0 {
        "inf"
    } else {
        "-inf"
    }
}

impl Serialize for Cell {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Cell::Text(t) => s.serialize_str(t),
            Cell::Int(n) => s.serialize_u64(*n),
            Cell::Num(v, _) | Cell::Psnr(v) if v.is_finite() => s.serialize_f64(*v),
            Cell::Psnr(v) if *v == f64::INFINITY => s.serialize_str(IDENTICAL),
            Cell::Num(v, _) | Cell::Psnr(v) => s.serialize_str(non_finite(*v)),
        }
    }
}

/// A table with a caption.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Table {
    /// Stable identifier (what `--verify` looks for).
    pub id: String,
    /// Caption.
    pub title: String,
    /// Column headers.
    pub columns: Vec<String>,
    /// Rows of cells, one per column.
    pub rows: Vec<Vec<Cell>>,
}

impl Table {
    /// An empty table.
    pub fn new(id: &str, title: impl Into<String>, columns: &[&str]) -> Self {
        Table {
            id: id.into(),
            title: title.into(),
            columns: columns.iter().map(|c| c.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row (as many cells as columns).
    pub fn row(&mut self, cells: Vec<Cell>) {
        debug_assert_eq!(cells.len(), self.columns.len(), "table {}", self.id);
        self.rows.push(cells);
    }

    /// GitHub-flavoured Markdown.
    pub fn markdown(&self) -> String {
        let mut s = format!("**{}**\n\n| {} |\n|", self.title, self.columns.join(" | "));
        s += &"---|".repeat(self.columns.len());
        s.push('\n');
        for r in &self.rows {
            let cells: Vec<String> = r.iter().map(|c| c.display().replace('|', "\\|")).collect();
            let _ = writeln!(s, "| {} |", cells.join(" | "));
        }
        s
    }

    fn html(&self) -> String {
        let mut s = format!(
            "<table id=\"{}\"><caption>{}</caption>\n<tr>",
            esc(&self.id),
            esc(&self.title)
        );
        for c in &self.columns {
            let _ = write!(s, "<th>{}</th>", esc(c));
        }
        s += "</tr>\n";
        for r in &self.rows {
            s += "<tr>";
            for c in r {
                let class = if matches!(c, Cell::Text(_)) {
                    ""
                } else {
                    " class=\"n\""
                };
                let _ = write!(s, "<td{class}>{}</td>", esc(&c.display()));
            }
            s += "</tr>\n";
        }
        s + "</table>\n"
    }
}

/// A pass/fail statement the report makes about its own numbers.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Check {
    /// What is claimed.
    pub claim: String,
    /// Whether the numbers support it.
    pub pass: bool,
    /// The numbers.
    pub detail: String,
}

/// Content of a section, in order.
#[derive(Clone, Debug)]
pub enum Block {
    /// A paragraph (plain text).
    Text(String),
    /// A table.
    Table(Table),
    /// An image, path relative to the report folder.
    Image { path: String, caption: String },
    /// A check.
    Check(Check),
}

/// One section of the report.
#[derive(Clone, Debug)]
pub struct Section {
    /// Stable identifier.
    pub id: &'static str,
    /// Heading.
    pub title: &'static str,
    /// Content.
    pub blocks: Vec<Block>,
    /// The section's raw numbers (the subcommand's own JSON).
    pub data: Value,
    /// Why the section could not be completed, when it could not.
    pub error: Option<String>,
    /// Wall time of the section, seconds.
    pub seconds: f64,
}

impl Section {
    /// An empty section.
    pub fn new(id: &'static str, title: &'static str) -> Self {
        Section {
            id,
            title,
            blocks: Vec::new(),
            data: Value::Null,
            error: None,
            seconds: 0.0,
        }
    }

    /// Appends a paragraph.
    pub fn text(&mut self, t: impl Into<String>) {
        self.blocks.push(Block::Text(t.into()));
    }

    /// Appends a table.
    pub fn table(&mut self, t: Table) {
        self.blocks.push(Block::Table(t));
    }

    /// Appends an image (path relative to the report folder).
    pub fn image(&mut self, path: impl Into<String>, caption: impl Into<String>) {
        self.blocks.push(Block::Image {
            path: path.into(),
            caption: caption.into(),
        });
    }

    /// Appends a check.
    pub fn check(&mut self, claim: impl Into<String>, pass: bool, detail: impl Into<String>) {
        self.blocks.push(Block::Check(Check {
            claim: claim.into(),
            pass,
            detail: detail.into(),
        }));
    }

    fn tables(&self) -> impl Iterator<Item = &Table> {
        self.blocks.iter().filter_map(|b| match b {
            Block::Table(t) => Some(t),
            _ => None,
        })
    }

    fn checks(&self) -> impl Iterator<Item = &Check> {
        self.blocks.iter().filter_map(|b| match b {
            Block::Check(c) => Some(c),
            _ => None,
        })
    }

    fn images(&self) -> impl Iterator<Item = &str> {
        self.blocks.iter().filter_map(|b| match b {
            Block::Image { path, .. } => Some(path.as_str()),
            _ => None,
        })
    }
}

/// The whole report.
pub struct Report {
    /// Page title.
    pub title: String,
    /// How to reproduce the page: machine, command line, revision, seed (key, value).
    pub provenance: Vec<(String, String)>,
    /// The sections.
    pub sections: Vec<Section>,
}

use crate::output::html_escape as esc;

fn check_line(c: &Check) -> String {
    format!(
        "{} {} — {}",
        if c.pass { "PASS" } else { "FAIL" },
        c.claim,
        c.detail
    )
}

impl Report {
    /// The report as Markdown.
    pub fn markdown(&self) -> String {
        let mut s = format!("# {}\n\n", self.title);
        for sec in &self.sections {
            let _ = writeln!(s, "## {}\n", sec.title);
            if let Some(e) = &sec.error {
                let _ = writeln!(s, "**This section failed:** {e}\n");
            }
            for b in &sec.blocks {
                match b {
                    Block::Text(t) => {
                        let _ = writeln!(s, "{t}\n");
                    }
                    Block::Table(t) => {
                        let _ = writeln!(s, "{}", t.markdown());
                    }
                    Block::Image { path, caption } => {
                        let _ = writeln!(s, "![{caption}]({path})\n\n*{caption}*\n");
                    }
                    Block::Check(c) => {
                        let _ = writeln!(s, "- **{}**\n", check_line(c));
                    }
                }
            }
            let _ = writeln!(s, "*Section time: {:.1} s.*\n", sec.seconds);
        }
        s += "## Reproduce\n\n| | |\n|---|---|\n";
        for (k, v) in &self.provenance {
            let _ = writeln!(s, "| {k} | `{}` |", v.replace('|', "\\|"));
        }
        s
    }

    /// The report as one HTML page (images are files beside it).
    pub fn html(&self) -> String {
        let mut s = format!(
            "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{t}</title>\n<style>\nbody{{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}}\ntable{{border-collapse:collapse;margin:1em 0}}caption{{text-align:left;font-weight:bold;padding:.3em 0}}\ntd,th{{border:1px solid #ccc;padding:.2em .5em}}td.n{{text-align:right;font-variant-numeric:tabular-nums}}\nimg{{max-width:100%;border:1px solid #ddd}}figure{{margin:1em 0}}\n.pass{{color:#070}}.fail{{color:#b00;font-weight:bold}}.error{{background:#fee;border:1px solid #b00;padding:.5em}}\nnav a{{margin-right:1em}}\n</style></head><body>\n<h1>{t}</h1>\n<nav>",
            t = esc(&self.title)
        );
        for sec in &self.sections {
            let _ = write!(s, "<a href=\"#{}\">{}</a>", sec.id, esc(sec.title));
        }
        s += "<a href=\"#reproduce\">Reproduce</a></nav>\n";
        for sec in &self.sections {
            let _ = writeln!(s, "<h2 id=\"{}\">{}</h2>", sec.id, esc(sec.title));
            if let Some(e) = &sec.error {
                let _ = writeln!(s, "<p class=\"error\">This section failed: {}</p>", esc(e));
            }
            for b in &sec.blocks {
                match b {
                    Block::Text(t) => {
                        let _ = writeln!(s, "<p>{}</p>", esc(t));
                    }
                    Block::Table(t) => s += &t.html(),
                    Block::Image { path, caption } => {
                        let _ = writeln!(
                            s,
                            "<figure><a href=\"{p}\"><img src=\"{p}\" alt=\"{c}\" loading=\"lazy\"></a><figcaption>{c}</figcaption></figure>",
                            p = esc(path),
                            c = esc(caption)
                        );
                    }
                    Block::Check(c) => {
                        let _ = writeln!(
                            s,
                            "<p class=\"{}\">{}</p>",
                            if c.pass { "pass" } else { "fail" },
                            esc(&check_line(c))
                        );
                    }
                }
            }
            let _ = writeln!(
                s,
                "<p><small>Section time: {:.1} s.</small></p>",
                sec.seconds
            );
        }
        s += "<h2 id=\"reproduce\">Reproduce</h2>\n<table>\n";
        for (k, v) in &self.provenance {
            let _ = writeln!(
                s,
                "<tr><th>{}</th><td><code>{}</code></td></tr>",
                esc(k),
                esc(v)
            );
        }
        s + "</table>\n</body></html>\n"
    }

    /// Every number of the report as JSON.
    pub fn json(&self) -> Value {
        json!({
            "title": self.title,
            "provenance": self.provenance.iter().map(|(k, v)| json!({"key": k, "value": v})).collect::<Vec<_>>(),
            "sections": self.sections.iter().map(|s| json!({
                "id": s.id,
                "title": s.title,
                "status": if s.error.is_some() { "failed" } else { "ok" },
                "error": s.error,
                "seconds": s.seconds,
                "tables": s.tables().collect::<Vec<_>>(),
                "checks": s.checks().collect::<Vec<_>>(),
                "images": s.images().collect::<Vec<_>>(),
                "data": s.data,
            })).collect::<Vec<_>>(),
        })
    }
}

/// Problems of a written report (its `report.json`): a section that is missing or failed, an
/// expected table missing or empty, a cell that is not a finite number or text (`NaN`,
/// `inf`), a check that failed, an image that does not exist.
pub fn verify(json: &Value, expected: &[(&str, &[&str])], dir: &std::path::Path) -> Vec<String> {
    let mut problems = Vec::new();
    let sections = json["sections"].as_array().cloned().unwrap_or_default();
    for (id, tables) in expected {
        let Some(sec) = sections.iter().find(|s| s["id"] == *id) else {
            problems.push(format!("section `{id}` is missing"));
            continue;
        };
        if sec["status"] != "ok" {
            problems.push(format!(
                "section `{id}` failed: {}",
                sec["error"].as_str().unwrap_or("(no message)")
            ));
        }
        let found = sec["tables"].as_array().cloned().unwrap_or_default();
        for t in *tables {
            match found.iter().find(|x| x["id"] == *t) {
                None => problems.push(format!("section `{id}`: table `{t}` is missing")),
                Some(x) if x["rows"].as_array().is_none_or(|r| r.is_empty()) => {
                    problems.push(format!("section `{id}`: table `{t}` has no rows"))
                }
                Some(_) => {}
            }
        }
        for t in &found {
            for (i, row) in t["rows"].as_array().into_iter().flatten().enumerate() {
                for (j, cell) in row.as_array().into_iter().flatten().enumerate() {
                    let bad = match cell {
                        Value::Number(n) => !n.as_f64().is_some_and(f64::is_finite),
                        Value::String(s) => matches!(s.as_str(), "NaN" | "inf" | "-inf"),
                        _ => true,
                    };
                    if bad {
                        problems.push(format!(
                            "section `{id}`, table `{}`, row {}, column {}: {cell} is not a finite number",
                            t["id"].as_str().unwrap_or("?"),
                            i + 1,
                            j + 1
                        ));
                    }
                }
            }
        }
        for c in sec["checks"].as_array().into_iter().flatten() {
            if c["pass"] != true {
                problems.push(format!(
                    "section `{id}`: check failed: {} — {}",
                    c["claim"].as_str().unwrap_or("?"),
                    c["detail"].as_str().unwrap_or("")
                ));
            }
        }
        for p in sec["images"].as_array().into_iter().flatten() {
            let p = p.as_str().unwrap_or("");
            if !dir.join(p).is_file() {
                problems.push(format!("section `{id}`: image {p} does not exist"));
            }
        }
    }
    problems
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(cell: Cell) -> Report {
        let mut s = Section::new("a", "A");
        let mut t = Table::new("t", "T", &["name", "value"]);
        t.row(vec![Cell::text("x"), cell]);
        s.table(t);
        Report {
            title: "r".into(),
            provenance: vec![],
            sections: vec![s],
        }
    }

    #[test]
    fn non_finite_numbers_are_found_and_identical_psnr_is_named() {
        let dir = std::env::temp_dir();
        let ok = report(Cell::Num(1.5, 2)).json();
        assert!(verify(&ok, &[("a", &["t"])], &dir).is_empty());
        for bad in [Cell::Num(f64::NAN, 2), Cell::Psnr(f64::NEG_INFINITY)] {
            let j = report(bad).json();
            assert_eq!(verify(&j, &[("a", &["t"])], &dir).len(), 1, "{j}");
        }
        let same = report(Cell::Psnr(f64::INFINITY));
        assert!(verify(&same.json(), &[("a", &["t"])], &dir).is_empty());
        assert!(same.markdown().contains(IDENTICAL));
        // Missing tables and sections are named.
        let p = verify(&ok, &[("a", &["t", "u"]), ("b", &[])], &dir);
        assert_eq!(p.len(), 2, "{p:?}");
    }

    #[test]
    fn failed_sections_and_checks_are_problems_and_html_is_escaped() {
        let mut r = report(Cell::Int(3));
        r.sections[0].error = Some("no <lights>".into());
        r.sections[0].check("x", false, "y");
        let p = verify(&r.json(), &[("a", &["t"])], &std::env::temp_dir());
        assert_eq!(p.len(), 2, "{p:?}");
        let html = r.html();
        assert!(html.contains("no &lt;lights&gt;"));
        assert!(!html.contains("<lights>"));
    }
}
