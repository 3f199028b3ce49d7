//! Mitsuba XML files as an owned element tree: `<default>` parameters and `$name`
//! substitution, `<include>` spliced in place (circular includes rejected), `<path>` search
//! directories collected. Every element keeps its file:line:column for messages.
//!
//! What the elements mean is decided elsewhere ([`super::props`] and the plugin readers); this
//! module knows only Mitsuba's preprocessing (src/core/parser.cpp).

use crate::error::FormatError;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A place in a scene file.
#[derive(Clone, Debug)]
pub(super) struct Loc {
    pub file: Arc<PathBuf>,
    pub line: u32,
    pub column: u32,
}

impl Loc {
    /// A value error at this place.
    pub fn error(&self, message: impl Into<String>) -> FormatError {
        FormatError::Value {
            file: self.file.as_ref().clone(),
            line: self.line as usize,
            column: self.column as usize,
            message: message.into(),
        }
    }

    /// "file:line:column", for warnings.
    pub fn describe(&self) -> String {
        format!("{}:{}:{}", self.file.display(), self.line, self.column)
    }

    /// The folder of the file this place is in.
    pub fn dir(&self) -> &Path {
        self.file.parent().unwrap_or(Path::new(""))
    }
}

/// One XML element after substitution and include expansion.
#[derive(Clone, Debug)]
pub(super) struct Element {
    pub tag: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    pub loc: Loc,
}

impl Element {
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs.iter().find(|(k, _)| k == name).map(|(_, v)| v.as_str())
    }

    /// An attribute that must be there.
    pub fn required(&self, name: &str) -> Result<&str, FormatError> {
        self.attr(name).ok_or_else(|| self.loc.error(format!("<{}> needs a '{name}' attribute", self.tag)))
    }

    /// `<tag type="…">` or `<tag>` for messages.
    pub fn describe(&self) -> String {
        match self.attr("type") {
            Some(t) => format!("<{} type=\"{t}\">", self.tag),
            None => format!("<{}>", self.tag),
        }
    }
}

/// Reads scene files: parameters, includes and the search path.
pub(super) struct Reader {
    /// Parameters from the caller (`-D name=value`): they win over `<default>`.
    params: HashMap<String, String>,
    /// Files being read, outermost first (for circular includes).
    stack: Vec<PathBuf>,
    /// Folders `<path>` added, in document order.
    pub search_paths: Vec<PathBuf>,
}

/// Largest scene file read (a scene's XML is small; meshes live in their own files).
const MAX_XML_BYTES: u64 = 256 << 20;
/// Deepest include nesting.
const MAX_INCLUDE_DEPTH: usize = 64;

impl Reader {
    pub fn new(defines: &[(String, String)]) -> Reader {
        Reader { params: defines.iter().cloned().collect(), stack: Vec::new(), search_paths: Vec::new() }
    }

    /// Reads `path` (its root must be `<scene>`), includes expanded.
    pub fn read(&mut self, path: &Path, from: Option<&Loc>) -> Result<Element, FormatError> {
        let field = from.map(|loc| format!("line {} <include filename>", loc.line));
        let by = from.zip(field.as_deref()).map(|(loc, field)| crate::files::Referrer::new(&loc.file, field));
        crate::files::check(path, by)?;
        let canonical = std::fs::canonicalize(path).map_err(|e| FormatError::io(path, e))?;
        if let Some(loc) = from {
            if self.stack.contains(&canonical) {
                let chain: Vec<String> = self.stack.iter().map(|p| p.display().to_string()).collect();
                return Err(loc.error(format!(
                    "circular include of {} (already being read: {})",
                    path.display(),
                    chain.join(" → ")
                )));
            }
            if self.stack.len() >= MAX_INCLUDE_DEPTH {
                return Err(loc.error(format!("includes nested deeper than {MAX_INCLUDE_DEPTH}")));
            }
        }
        let size = std::fs::metadata(path).map_err(|e| FormatError::io(path, e))?.len();
        if size > MAX_XML_BYTES {
            return Err(FormatError::limits(
                path,
                format!("scene file of {size} bytes is larger than {MAX_XML_BYTES}"),
            ));
        }
        let text = crate::files::read_text(path, None, "a Mitsuba XML scene")?;
        let file = Arc::new(path.to_path_buf());
        let doc = roxmltree::Document::parse(&text).map_err(|e| {
            let pos = e.pos();
            FormatError::Syntax {
                file: path.to_path_buf(),
                line: pos.row as usize,
                column: pos.col as usize,
                message: e.to_string(),
            }
        })?;
        let root = doc.root_element();
        let loc = loc_of(&doc, root, &file);
        if root.tag_name().name() != "scene" {
            return Err(
                loc.error(format!("the root element is <{}>, a Mitsuba scene's is <scene>", root.tag_name().name()))
            );
        }
        self.stack.push(canonical);
        let mut scene = Element { tag: "scene".into(), attrs: Vec::new(), children: Vec::new(), loc };
        let result = self.children(&doc, root, &file, &mut scene.children);
        self.stack.pop();
        result?;
        Ok(scene)
    }

    fn children(
        &mut self,
        doc: &roxmltree::Document,
        node: roxmltree::Node,
        file: &Arc<PathBuf>,
        out: &mut Vec<Element>,
    ) -> Result<(), FormatError> {
        for child in node.children().filter(roxmltree::Node::is_element) {
            let loc = loc_of(doc, child, file);
            let tag = child.tag_name().name();
            let mut attrs = Vec::new();
            for a in child.attributes() {
                attrs.push((a.name().to_string(), self.substitute(a.value(), &loc)?));
            }
            let el = Element { tag: tag.to_string(), attrs, children: Vec::new(), loc };
            match tag {
                "default" => {
                    let name = el.required("name")?.to_string();
                    let value = el.required("value")?.to_string();
                    self.params.entry(name).or_insert(value);
                }
                "include" => {
                    let target = el.loc.dir().join(el.required("filename")?);
                    let included = self.read(&target, Some(&el.loc))?;
                    out.extend(included.children);
                }
                "path" => {
                    let dir = el.loc.dir().join(el.required("value")?);
                    if !dir.is_dir() {
                        return Err(el.loc.error(format!("<path>: {} is not a folder", dir.display())));
                    }
                    self.search_paths.push(dir);
                }
                _ => {
                    let mut el = el;
                    self.children(doc, child, file, &mut el.children)?;
                    out.push(el);
                }
            }
        }
        Ok(())
    }

    /// Replaces every `$name` (name: letters, digits, `_`) by its parameter.
    fn substitute(&self, value: &str, loc: &Loc) -> Result<String, FormatError> {
        if !value.contains('$') {
            return Ok(value.to_string());
        }
        let mut out = String::with_capacity(value.len());
        let mut rest = value;
        while let Some(i) = rest.find('$') {
            out.push_str(&rest[..i]);
            let after = &rest[i + 1..];
            let len = after.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(after.len());
            let name = &after[..len];
            if name.is_empty() {
                return Err(loc.error(format!("'$' without a parameter name in \"{value}\"")));
            }
            match self.params.get(name) {
                Some(v) => out.push_str(v),
                None => {
                    return Err(loc.error(format!(
                        "parameter ${name} has no value: give it one with <default name=\"{name}\" value=\"…\"/> or define it (-D {name}=…)"
                    )));
                }
            }
            rest = &after[len..];
        }
        out.push_str(rest);
        Ok(out)
    }
}

fn loc_of(doc: &roxmltree::Document, node: roxmltree::Node, file: &Arc<PathBuf>) -> Loc {
    let pos = doc.text_pos_at(node.range().start);
    Loc { file: file.clone(), line: pos.row, column: pos.col }
}
