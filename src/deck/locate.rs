//! Maps between key paths (`boundary_conditions[1].value`) and places in the deck text
//! (line:column), so every error can name both.

use std::fmt;
use std::ops::Range;
use toml_edit::{ImDocument, Item, Value};

/// One step of a key path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PathElem {
    Key(String),
    Index(usize),
}

/// A key path into the deck, e.g. `material.youngs_modulus`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct KeyPath(pub Vec<PathElem>);

impl KeyPath {
    pub fn key(&self, k: &str) -> KeyPath {
        let mut p = self.clone();
        p.0.push(PathElem::Key(k.to_string()));
        p
    }
    pub fn index(&self, i: usize) -> KeyPath {
        let mut p = self.clone();
        p.0.push(PathElem::Index(i));
        p
    }
    /// Parses `a.b[2].c`.
    pub fn parse(s: &str) -> KeyPath {
        let mut out = Vec::new();
        for part in s.split('.').filter(|p| !p.is_empty()) {
            let mut rest = part;
            if let Some(k) = rest.find('[') {
                if k > 0 {
                    out.push(PathElem::Key(rest[..k].to_string()));
                }
                rest = &rest[k..];
                while let Some(stripped) = rest.strip_prefix('[') {
                    let end = stripped.find(']').unwrap_or(stripped.len());
                    if let Ok(i) = stripped[..end].parse() {
                        out.push(PathElem::Index(i));
                    }
                    rest = stripped.get(end + 1..).unwrap_or("");
                }
            } else {
                out.push(PathElem::Key(rest.to_string()));
            }
        }
        KeyPath(out)
    }
}

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (n, e) in self.0.iter().enumerate() {
            match e {
                PathElem::Key(k) if n == 0 => write!(f, "{k}")?,
                PathElem::Key(k) => write!(f, ".{k}")?,
                PathElem::Index(i) => write!(f, "[{i}]")?,
            }
        }
        Ok(())
    }
}

/// 1-based line and column of a byte offset.
pub fn line_col(src: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(src.len());
    let before = &src[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map(|l| l.chars().count()).unwrap_or(0) + 1;
    (line, col)
}

/// A parsed deck text that keeps spans.
pub struct Located {
    doc: Option<ImDocument<String>>,
}

impl Located {
    pub fn new(src: &str) -> Self {
        Located { doc: ImDocument::parse(src.to_string()).ok() }
    }

    /// The span of the key at `path` (or of the value for array elements); falls back to the
    /// deepest existing ancestor.
    pub fn span_of(&self, path: &KeyPath) -> Option<Range<usize>> {
        let doc = self.doc.as_ref()?;
        let mut best = None;
        let mut item: Option<Node> = Some(Node::of(doc.as_item()));
        for e in &path.0 {
            let Some(node) = item.take() else { break };
            match (node, e) {
                (node, PathElem::Key(k)) => {
                    if let Some((key, child)) = node.get_key(k) {
                        best = key.or(child.span()).or(best);
                        item = Some(child);
                    }
                }
                (node, PathElem::Index(i)) => {
                    if let Some(child) = node.get_index(*i) {
                        best = child.span().or(best);
                        item = Some(child);
                    }
                }
            }
        }
        best
    }

    /// The deepest key path whose key or value contains `offset`.
    pub fn path_at(&self, offset: usize) -> KeyPath {
        let mut out = KeyPath::default();
        if let Some(doc) = &self.doc {
            descend(Node::of(doc.as_item()), offset, &mut out);
        }
        out
    }
}

#[derive(Clone, Copy)]
enum Node<'a> {
    Item(&'a Item),
    Table(&'a toml_edit::Table),
    Value(&'a Value),
}

impl<'a> Node<'a> {
    /// Normalises tables so lookups need one arm per container kind.
    fn of(item: &'a Item) -> Node<'a> {
        match item {
            Item::Table(t) => Node::Table(t),
            Item::Value(v) => Node::Value(v),
            other => Node::Item(other),
        }
    }
    fn span(&self) -> Option<Range<usize>> {
        match self {
            Node::Item(i) => i.span(),
            Node::Table(t) => t.span(),
            Node::Value(v) => v.span(),
        }
    }
    fn keys(&self) -> Vec<String> {
        match self {
            Node::Table(t) => t.iter().map(|(k, _)| k.to_string()).collect(),
            Node::Value(Value::InlineTable(t)) => t.iter().map(|(k, _)| k.to_string()).collect(),
            _ => Vec::new(),
        }
    }
    fn len(&self) -> usize {
        match self {
            Node::Item(Item::ArrayOfTables(a)) => a.len(),
            Node::Value(Value::Array(a)) => a.len(),
            _ => 0,
        }
    }
    fn get_key(&self, k: &str) -> Option<(Option<Range<usize>>, Node<'a>)> {
        match self {
            Node::Table(t) => t.get_key_value(k).map(|(key, item)| (key.span(), Node::of(item))),
            Node::Value(Value::InlineTable(t)) => t.get_key_value(k).map(|(key, item)| (key.span(), Node::of(item))),
            _ => None,
        }
    }
    fn get_index(&self, i: usize) -> Option<Node<'a>> {
        match self {
            Node::Item(Item::ArrayOfTables(a)) => a.get(i).map(Node::Table),
            Node::Value(Value::Array(a)) => a.get(i).map(Node::Value),
            _ => None,
        }
    }
}

fn descend(node: Node, offset: usize, path: &mut KeyPath) {
    for k in node.keys() {
        if let Some((key_span, child)) = node.get_key(&k) {
            let in_key = key_span.map(|r| r.contains(&offset)).unwrap_or(false);
            let in_val = child.span().map(|r| r.contains(&offset)).unwrap_or(false);
            let mut sub = path.key(&k);
            let before = sub.0.len();
            descend(child, offset, &mut sub);
            if sub.0.len() > before || in_key || in_val {
                *path = sub;
                return;
            }
        }
    }
    for i in 0..node.len() {
        if let Some(child) = node.get_index(i) {
            let in_val = child.span().map(|r| r.contains(&offset)).unwrap_or(false);
            let mut sub = path.index(i);
            let before = sub.0.len();
            descend(child, offset, &mut sub);
            if sub.0.len() > before || in_val {
                *path = sub;
                return;
            }
        }
    }
}
