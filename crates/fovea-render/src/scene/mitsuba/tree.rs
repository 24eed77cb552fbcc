//! The scene XML as an owned tree of [`XNode`]s: parsing with `roxmltree` (malformed XML and
//! non-UTF-8 text are `BadInput` with the position), `<include filename>` splicing (resolved
//! against the including file's folder, then the folders seen so far; nesting at most
//! `MAX_DEPTH`, cycles rejected), `<default name value>` parameters (first wins) and `$name`
//! substitution in attribute values (unknown names left as written), the id table for
//! `<ref id>`, and parameter-name matching that ignores case and underscores (Mitsuba 0.6
//! `toWorld` = Mitsuba 2/3 `to_world`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::{bad, MAX_DEPTH};
use crate::error::{RenderError, Result};

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

/// Reads and parses `path` into an owned tree, splicing includes.
pub(super) fn read_tree(
    path: &Path,
    stack: &mut Vec<PathBuf>,
    dirs: &mut Vec<PathBuf>,
) -> Result<XNode> {
    let bytes = std::fs::read(path).map_err(|e| RenderError::io(path, &e))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        bad(
            path,
            format!(
                "malformed XML: not UTF-8 text (byte {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })?;
    let doc =
        roxmltree::Document::parse(&text).map_err(|e| bad(path, format!("malformed XML: {e}")))?;
    let file = Arc::new(path.to_path_buf());
    let root = doc.root_element();
    stack.push(path.canonicalize().unwrap_or_else(|_| path.to_path_buf()));
    let out = convert_node(&doc, root, &file, stack, dirs);
    stack.pop();
    out
}

fn convert_node(
    doc: &roxmltree::Document,
    node: roxmltree::Node,
    file: &Arc<PathBuf>,
    stack: &mut Vec<PathBuf>,
    dirs: &mut Vec<PathBuf>,
) -> Result<XNode> {
    let line = doc.text_pos_at(node.range().start).row;
    let mut out = XNode {
        tag: node.tag_name().name().to_string(),
        attrs: node
            .attributes()
            .map(|a| (a.name().to_string(), a.value().to_string()))
            .collect(),
        children: Vec::new(),
        file: file.clone(),
        line,
    };
    for child in node.children().filter(|c| c.is_element()) {
        if child.tag_name().name() == "include" {
            let Some(rel) = child.attribute("filename") else {
                return Err(bad(
                    file,
                    format!(
                        "line {}: <include> without a filename",
                        doc.text_pos_at(child.range().start).row
                    ),
                ));
            };
            if stack.len() as u32 >= MAX_DEPTH {
                return Err(bad(
                    file,
                    format!("<include> nested deeper than {MAX_DEPTH}"),
                ));
            }
            let here = file.parent().map(Path::to_path_buf).unwrap_or_default();
            let mut target = here.join(rel);
            if !target.exists() {
                if let Some(alt) = dirs.iter().map(|d| d.join(rel)).find(|p| p.exists()) {
                    target = alt;
                }
            }
            if !target.exists() {
                return Err(bad(
                    file,
                    format!(
                        "line {}: included file {} does not exist",
                        doc.text_pos_at(child.range().start).row,
                        target.display()
                    ),
                ));
            }
            let canon = target.canonicalize().unwrap_or_else(|_| target.clone());
            if stack.contains(&canon) {
                return Err(bad(
                    file,
                    format!("<include> cycle through {}", target.display()),
                ));
            }
            if let Some(d) = target.parent() {
                if !dirs.iter().any(|x| x == d) {
                    dirs.push(d.to_path_buf());
                }
            }
            let sub = read_tree(&target, stack, dirs)?;
            out.children.extend(sub.children);
        } else {
            out.children
                .push(convert_node(doc, child, file, stack, dirs)?);
        }
    }
    Ok(out)
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
    fn norm_eq_ignores_case_and_underscores() {
        assert!(norm_eq("toWorld", "to_world"));
        assert!(norm_eq("diffuse_reflectance", "diffuseReflectance"));
        assert!(!norm_eq("alpha", "alphaU"));
    }
}
