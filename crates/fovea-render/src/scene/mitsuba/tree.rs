//! The scene XML as an owned tree of [`XNode`]s: parsing with `roxmltree` (malformed XML and
//! non-UTF-8 text are `BadInput` with the position), `<include filename>` splicing (resolved
//! against the including file's folder, then the folders seen so far; nesting at most
//! `MAX_DEPTH`, cycles rejected), `<default name value>` parameters (first wins) and `$name`
//! substitution in attribute values (unknown names left as written), the id table for
//! `<ref id>`, and parameter-name matching that ignores case and underscores (Mitsuba 0.6
//! `toWorld` = Mitsuba 2/3 `to_world`).
//!
//! Bounds: files are read through the load's `SceneFiles` (regular files inside the scene's
//! folder, within the size limits). `roxmltree` parses iteratively (no recursion per level);
//! the owned tree is built recursively, so elements nested deeper than
//! [`LoadLimits::max_nesting`](crate::scene::LoadLimits::max_nesting) (includes spliced in)
//! are refused with a `ResourceLimit` before the recursion goes further; every later walk of
//! the tree is then bounded too. Line numbers come from a table of line starts (a binary
//! search per element), so building the tree is linear in the file's size.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::{bad, MAX_DEPTH};
use crate::error::{RenderError, Result};
use crate::scene::files::SceneFiles;

/// An XML element with includes spliced in and `$` parameters substituted.
#[derive(Debug)]
pub(super) struct XNode {
    pub(super) tag: String,
    pub(super) attrs: Vec<(String, String)>,
    pub(super) children: Vec<XNode>,
    pub(super) file: Arc<PathBuf>,
    pub(super) line: u32,
}

impl XNode {
    pub(super) fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// `file:line` for messages.
    pub(super) fn at(&self) -> String {
        format!(
            "{} line {}",
            self.file
                .file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            self.line
        )
    }

    /// `type` attribute or "".
    pub(super) fn ty(&self) -> &str {
        self.attr("type").unwrap_or("")
    }

    /// Whether the `name` attribute matches one of `names` (case and `_` ignored).
    pub(super) fn named(&self, names: &[&str]) -> bool {
        self.attr("name")
            .is_some_and(|n| names.iter().any(|w| norm_eq(n, w)))
    }

    /// First child with the given tag whose `name` matches.
    pub(super) fn param(&self, tags: &[&str], names: &[&str]) -> Option<&XNode> {
        self.children
            .iter()
            .find(|c| tags.contains(&c.tag.as_str()) && c.named(names))
    }
}

fn norm_eq(a: &str, b: &str) -> bool {
    let mut x = a.chars().filter(|c| *c != '_');
    let mut y = b.chars().filter(|c| *c != '_');
    loop {
        match (x.next(), y.next()) {
            (None, None) => return true,
            (Some(p), Some(q)) if p.eq_ignore_ascii_case(&q) => {}
            _ => return false,
        }
    }
}

/// Line numbers of byte offsets: the offsets where lines start, searched by bisection
/// (`roxmltree::Document::text_pos_at` scans the text from its start, which made loading
/// quadratic in the number of elements).
struct LineIndex {
    starts: Vec<usize>,
}

impl LineIndex {
    fn new(text: &str) -> Self {
        let mut starts = vec![0];
        starts.extend(
            text.bytes()
                .enumerate()
                .filter(|&(_, b)| b == b'\n')
                .map(|(i, _)| i + 1),
        );
        Self { starts }
    }

    /// 1-based line of byte offset `pos`.
    fn line(&self, pos: usize) -> u32 {
        self.starts.partition_point(|&s| s <= pos) as u32
    }
}

/// What one parse needs while it builds the tree: the load's files, the include stack, the
/// folders seen so far.
pub(super) struct TreeReader<'f> {
    pub(super) files: &'f SceneFiles,
    pub(super) stack: Vec<PathBuf>,
    pub(super) dirs: Vec<PathBuf>,
}

/// One parsed file: its path and line table.
struct Source {
    file: Arc<PathBuf>,
    lines: LineIndex,
}

impl Source {
    fn line_of(&self, node: roxmltree::Node) -> u32 {
        self.lines.line(node.range().start)
    }
}

/// The text of an XML file (UTF-8; UTF-16 and other bytes are named in the error).
fn xml_text(path: &Path, bytes: Vec<u8>) -> Result<String> {
    String::from_utf8(bytes).map_err(|e| {
        let b = e.as_bytes();
        let what = if b.starts_with(&[0xFF, 0xFE]) || b.starts_with(&[0xFE, 0xFF]) {
            "malformed XML: UTF-16 text; only UTF-8 is read (convert it, e.g. with iconv)"
                .to_string()
        } else {
            format!(
                "malformed XML: not UTF-8 text (byte {})",
                e.utf8_error().valid_up_to()
            )
        };
        bad(path, what)
    })
}

impl TreeReader<'_> {
    /// Reads and parses `path` into an owned tree, splicing includes. `main`: the scene file
    /// itself (read wherever it lies); includes must lie in the scene's folder. `depth`:
    /// nesting of the element that includes this file (0 for the scene file).
    pub(super) fn read_tree(&mut self, path: &Path, main: bool, depth: u32) -> Result<XNode> {
        let bytes = if main {
            self.files.read_scene_file()?
        } else {
            self.files.read(path, None)?
        };
        let text = xml_text(path, bytes)?;
        let doc = roxmltree::Document::parse(&text)
            .map_err(|e| bad(path, format!("malformed XML: {e}")))?;
        let src = Source {
            file: Arc::new(path.to_path_buf()),
            lines: LineIndex::new(&text),
        };
        let root = doc.root_element();
        self.stack
            .push(path.canonicalize().unwrap_or_else(|_| path.to_path_buf()));
        let out = self.convert_node(&src, root, depth);
        self.stack.pop();
        out
    }

    fn convert_node(&mut self, src: &Source, node: roxmltree::Node, depth: u32) -> Result<XNode> {
        let line = src.line_of(node);
        let max = self.files.limits().max_nesting;
        if depth >= max {
            return Err(RenderError::ResourceLimit {
                what: format!(
                    "XML of {} (line {line}, includes spliced in)",
                    src.file.display()
                ),
                needed: format!("elements nested more than {max} deep"),
                limit: format!("max_nesting = {max}"),
            });
        }
        let mut out = XNode {
            tag: node.tag_name().name().to_string(),
            attrs: node
                .attributes()
                .map(|a| (a.name().to_string(), a.value().to_string()))
                .collect(),
            children: Vec::new(),
            file: src.file.clone(),
            line,
        };
        for child in node.children().filter(|c| c.is_element()) {
            if child.tag_name().name() == "include" {
                let row = src.line_of(child);
                let Some(rel) = child.attribute("filename") else {
                    return Err(bad(
                        &src.file,
                        format!("line {row}: <include> without a filename"),
                    ));
                };
                if self.stack.len() as u32 >= MAX_DEPTH {
                    return Err(bad(
                        &src.file,
                        format!("<include> nested deeper than {MAX_DEPTH}"),
                    ));
                }
                let here = src.file.parent().map(Path::to_path_buf).unwrap_or_default();
                let mut target = here.join(rel);
                if !target.exists() {
                    if let Some(alt) = self.dirs.iter().map(|d| d.join(rel)).find(|p| p.exists()) {
                        target = alt;
                    }
                }
                if !target.exists() {
                    return Err(bad(
                        &src.file,
                        format!(
                            "line {row}: included file {} does not exist",
                            target.display()
                        ),
                    ));
                }
                let canon = target.canonicalize().unwrap_or_else(|_| target.clone());
                if self.stack.contains(&canon) {
                    return Err(bad(
                        &src.file,
                        format!("<include> cycle through {}", target.display()),
                    ));
                }
                if let Some(d) = target.parent() {
                    if !self.dirs.iter().any(|x| x == d) {
                        self.dirs.push(d.to_path_buf());
                    }
                }
                // The included root's children take the include's place: one level below
                // `node`, like the include element itself.
                let sub = self.read_tree(&target, false, depth)?;
                out.children.extend(sub.children);
            } else {
                out.children.push(self.convert_node(src, child, depth + 1)?);
            }
        }
        Ok(out)
    }
}

pub(super) fn collect_defaults(node: &XNode, out: &mut HashMap<String, String>) {
    if node.tag == "default" {
        if let (Some(n), Some(v)) = (node.attr("name"), node.attr("value")) {
            out.entry(n.to_string()).or_insert_with(|| v.to_string());
        }
    }
    for c in &node.children {
        collect_defaults(c, out);
    }
}

/// Replaces `$name` by the parameter's value; unknown names are left as written.
fn substitute(s: &str, params: &HashMap<String, String>) -> String {
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(i) = rest.find('$') {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        let len = after
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .unwrap_or(after.len());
        let name = &after[..len];
        match params.get(name) {
            Some(v) if !name.is_empty() => out.push_str(v),
            _ => {
                out.push('$');
                out.push_str(name);
            }
        }
        rest = &after[len..];
    }
    out.push_str(rest);
    out
}

pub(super) fn substitute_tree(node: &mut XNode, params: &HashMap<String, String>) {
    for (_, v) in &mut node.attrs {
        if v.contains('$') {
            *v = substitute(v, params);
        }
    }
    for c in &mut node.children {
        substitute_tree(c, params);
    }
}

pub(super) fn collect_ids<'t>(
    node: &'t XNode,
    ids: &mut HashMap<&'t str, &'t XNode>,
    warnings: &mut Vec<String>,
) {
    for c in &node.children {
        if c.tag != "ref" {
            if let Some(id) = c.attr("id") {
                if ids.contains_key(id) {
                    warnings.push(format!(
                        "{}: duplicate id `{id}`, the first is used",
                        c.at()
                    ));
                } else {
                    ids.insert(id, c);
                }
            }
        }
        collect_ids(c, ids, warnings);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn substitution_keeps_unknown_names() {
        let mut p = HashMap::new();
        p.insert("a".to_string(), "1".to_string());
        assert_eq!(substitute("$a", &p), "1");
        assert_eq!(substitute("x$a,$b $", &p), "x1,$b $");
        assert_eq!(substitute("$method", &p), "$method");
    }

    #[test]
    fn line_index_matches_roxmltree() {
        let text = "<a>\n <b/>\n\n<c\n/></a>";
        let doc = roxmltree::Document::parse(text).unwrap();
        let lines = LineIndex::new(text);
        for n in doc.descendants() {
            let p = n.range().start;
            assert_eq!(lines.line(p), doc.text_pos_at(p).row, "{p}");
        }
    }

    #[test]
    fn norm_eq_ignores_case_and_underscores() {
        assert!(norm_eq("toWorld", "to_world"));
        assert!(norm_eq("diffuse_reflectance", "diffuseReflectance"));
        assert!(!norm_eq("alpha", "alphaU"));
    }
}
