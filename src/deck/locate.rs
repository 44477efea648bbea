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
    let col = before
        .rsplit('\n')
        .next()
        .map(|l| l.chars().count())
        .unwrap_or(0)
        + 1;
    (line, col)
}

/// A parsed deck text that keeps spans.
pub struct Located {
    doc: Option<ImDocument<String>>,
}

impl Located {
    pub fn new(src: &str) -> Self {
        Located {
            doc: ImDocument::parse(src.to_string()).ok(),
        }
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

    /// Narrows a parse error whose span covers a whole table. Inside internally tagged enums
    /// (`type = "..."` tables: material, discretization, solver, loads, shapes, pre-cracks,
    /// time functions) serde reports errors without a span, so the error lands on the enclosing
    /// table. This finds, under `path`, the key the message names (`unknown field `k``), the
    /// `type` key of an `unknown variant `v``, or the value it quotes (`invalid type: string "s"`,
    /// `invalid value: integer `n``, `invalid length n`), and returns its path and span.
    pub fn refine(&self, path: &KeyPath, message: &str) -> Option<(KeyPath, Range<usize>)> {
        let doc = self.doc.as_ref()?;
        let mut node = Node::of(doc.as_item());
        for e in &path.0 {
            node = match e {
                PathElem::Key(k) => node.get_key(k)?.1,
                PathElem::Index(i) => node.get_index(*i)?,
            };
        }
        if !matches!(
            node,
            Node::Table(_)
                | Node::Value(Value::InlineTable(_))
                | Node::Item(Item::ArrayOfTables(_))
        ) {
            return None;
        }
        let target = Target::from_message(message)?;
        let mut found = None;
        find(node, path.clone(), &target, &mut found);
        found
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
            Node::Table(t) => t
                .get_key_value(k)
                .map(|(key, item)| (key.span(), Node::of(item))),
            Node::Value(Value::InlineTable(t)) => t
                .get_key_value(k)
                .map(|(key, item)| (key.span(), Node::of(item))),
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

/// What a serde message points at.
enum Target {
    Key(String),
    Variant(String),
    Str(String),
    Int(i64),
    Float(f64),
    Bool(bool),
    Length(usize),
}

impl Target {
    fn from_message(m: &str) -> Option<Target> {
        let quoted = |prefix: &str, open: char, close: char| -> Option<String> {
            let rest = m.split(prefix).nth(1)?;
            let rest = rest.strip_prefix(open)?;
            Some(rest[..rest.find(close)?].to_string())
        };
        if let Some(k) = quoted("unknown field ", '`', '`') {
            return Some(Target::Key(k));
        }
        if let Some(v) = quoted("unknown variant ", '`', '`') {
            return Some(Target::Variant(v));
        }
        if let Some(s) = quoted(": string ", '"', '"') {
            return Some(Target::Str(s));
        }
        if let Some(n) = quoted(": integer ", '`', '`') {
            return n.parse().ok().map(Target::Int);
        }
        if let Some(x) = quoted(": floating point ", '`', '`') {
            return x.parse().ok().map(Target::Float);
        }
        if let Some(b) = quoted(": boolean ", '`', '`') {
            return b.parse().ok().map(Target::Bool);
        }
        let n = m
            .split("invalid length ")
            .nth(1)?
            .split(|c: char| !c.is_ascii_digit())
            .next()?;
        n.parse().ok().map(Target::Length)
    }

    fn matches_value(&self, v: &Value) -> bool {
        match (self, v) {
            (Target::Str(s), Value::String(x)) => x.value() == s,
            (Target::Int(n), Value::Integer(x)) => x.value() == n,
            (Target::Float(f), Value::Float(x)) => x.value() == f,
            (Target::Bool(b), Value::Boolean(x)) => x.value() == b,
            (Target::Length(n), Value::Array(a)) => a.len() == *n,
            _ => false,
        }
    }
}

/// Depth-first, in document order: the first key or value under `node` that `target` names.
fn find(node: Node, path: KeyPath, target: &Target, found: &mut Option<(KeyPath, Range<usize>)>) {
    if found.is_some() {
        return;
    }
    for k in node.keys() {
        let Some((key_span, child)) = node.get_key(&k) else {
            continue;
        };
        let here = path.key(&k);
        let hit = match (target, child) {
            (Target::Key(name), _) => *name == k,
            (Target::Variant(v), Node::Value(Value::String(s))) => k == "type" && s.value() == v,
            (_, Node::Value(v)) => target.matches_value(v),
            _ => false,
        };
        if hit {
            let span = if matches!(target, Target::Key(_)) {
                key_span.or(child.span())
            } else {
                child.span().or(key_span)
            };
            if let Some(span) = span {
                *found = Some((here, span));
                return;
            }
        }
        find(child, here, target, found);
        if found.is_some() {
            return;
        }
    }
    for i in 0..node.len() {
        let Some(child) = node.get_index(i) else {
            continue;
        };
        let here = path.index(i);
        if let Node::Value(v) = child {
            if !matches!(target, Target::Key(_) | Target::Variant(_)) && target.matches_value(v) {
                if let Some(span) = child.span() {
                    *found = Some((here, span));
                    return;
                }
            }
        }
        find(child, here, target, found);
        if found.is_some() {
            return;
        }
    }
}
