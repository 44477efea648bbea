//! Numbers (and words: a solver's method) in deck text read and replaced by key path
//! (`material.youngs_modulus`, `boundary_conditions[1].value`), keeping every other byte:
//! comments, layout and line numbers stay, so a problem in an edited deck is located where it
//! is in the original.

use super::locate::PathElem;
use super::KeyPath;
use toml_edit::{DocumentMut, Item, Table, Value};

/// The number at `path` in deck text, or why there is none.
pub fn number_at(src: &str, path: &KeyPath) -> Result<f64, String> {
    let mut doc = parse(src)?;
    match number_slot(&mut doc, path)? {
        Value::Float(f) => Ok(*f.value()),
        Value::Integer(i) => Ok(*i.value() as f64),
        _ => unreachable!("`number_slot` returns numbers only"),
    }
}

/// Deck text with the number at `path` replaced by `value`; an integer key (a seed, a step
/// count) takes `value` rounded to the nearest integer.
pub fn set_number(src: &str, path: &KeyPath, value: f64) -> Result<String, String> {
    if !value.is_finite() {
        return Err(format!("`{path}` cannot be set to {value}"));
    }
    let mut doc = parse(src)?;
    let slot = number_slot(&mut doc, path)?;
    let mut new = match slot {
        Value::Integer(_) => Value::from(value.round() as i64),
        _ => Value::from(value),
    };
    *new.decor_mut() = slot.decor().clone();
    *slot = new;
    Ok(doc.to_string())
}

/// A value a study or a validation case sets in every run: a number, or a word of the deck
/// (a solver's `preconditioner = "two_level"`).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(untagged)]
pub enum DeckValue {
    Number(f64),
    Word(String),
}

/// Deck text with the value at `path` replaced by `value`, which must be of the kind the deck
/// holds there (a number for a number, a word for a word).
pub fn set_value(src: &str, path: &KeyPath, value: &DeckValue) -> Result<String, String> {
    match value {
        DeckValue::Number(v) => set_number(src, path, *v),
        DeckValue::Word(w) => {
            let mut doc = parse(src)?;
            let slot = word_slot(&mut doc, path)?;
            let mut new = Value::from(w.as_str());
            *new.decor_mut() = slot.decor().clone();
            *slot = new;
            Ok(doc.to_string())
        }
    }
}

/// Why `value` cannot be set at `path` (no such key, or a value of another kind there).
pub fn settable(src: &str, path: &KeyPath, value: &DeckValue) -> Result<(), String> {
    match value {
        DeckValue::Number(_) => number_at(src, path).map(|_| ()),
        DeckValue::Word(_) => word_slot(&mut parse(src)?, path).map(|_| ()),
    }
}

fn parse(src: &str) -> Result<DocumentMut, String> {
    src.parse::<DocumentMut>()
        .map_err(|e| format!("the deck is not valid TOML: {}", e.message().trim()))
}

/// The value at `path`, which must be an integer or a float.
fn number_slot<'a>(doc: &'a mut DocumentMut, path: &KeyPath) -> Result<&'a mut Value, String> {
    let value = in_item(doc.as_item_mut(), &path.0)
        .ok_or_else(|| format!("the deck has no number at `{path}`"))?;
    match value {
        Value::Float(_) | Value::Integer(_) => Ok(value),
        other => Err(format!("`{path}` holds {}, not a number", kind(other))),
    }
}

/// The value at `path`, which must be a string.
fn word_slot<'a>(doc: &'a mut DocumentMut, path: &KeyPath) -> Result<&'a mut Value, String> {
    let value = in_item(doc.as_item_mut(), &path.0)
        .ok_or_else(|| format!("the deck has no word at `{path}`"))?;
    match value {
        Value::String(_) => Ok(value),
        other => Err(format!("`{path}` holds {}, not a word", kind(other))),
    }
}

/// What a deck value is, with its article ("an integer").
fn kind(value: &Value) -> String {
    let name = value.type_name();
    let article = if name.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "an"
    } else {
        "a"
    };
    format!("{article} {name}")
}

fn in_item<'a>(item: &'a mut Item, rest: &[PathElem]) -> Option<&'a mut Value> {
    let Some((first, tail)) = rest.split_first() else {
        return item.as_value_mut();
    };
    match (first, item) {
        (PathElem::Key(k), Item::Table(t)) => in_item(t.get_mut(k)?, tail),
        (PathElem::Index(i), Item::ArrayOfTables(a)) => in_table(a.get_mut(*i)?, tail),
        (_, Item::Value(v)) => in_value(v, rest),
        _ => None,
    }
}

fn in_table<'a>(table: &'a mut Table, rest: &[PathElem]) -> Option<&'a mut Value> {
    match rest.split_first()? {
        (PathElem::Key(k), tail) => in_item(table.get_mut(k)?, tail),
        _ => None,
    }
}

fn in_value<'a>(value: &'a mut Value, rest: &[PathElem]) -> Option<&'a mut Value> {
    let Some((first, tail)) = rest.split_first() else {
        return Some(value);
    };
    match (first, value) {
        (PathElem::Key(k), Value::InlineTable(t)) => in_value(t.get_mut(k)?, tail),
        (PathElem::Index(i), Value::Array(a)) => in_value(a.get_mut(*i)?, tail),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DECK: &str = r#"# a comment
version = 1
[material]
type = "pmb"
youngs_modulus = 3.0e9   # Pa
seed = 7

[[boundary_conditions]]
set = "top"
value = 1.0

[[boundary_conditions]]
set = "bottom"
value = -1.0
region = { type = "disk", center = [0.5, 0.25], radius = 0.1 }
"#;

    #[test]
    fn numbers_are_read_and_replaced_in_place() {
        let e = KeyPath::parse("material.youngs_modulus");
        assert_eq!(number_at(DECK, &e).unwrap(), 3.0e9);
        let edited = set_number(DECK, &e, 2.5e9).unwrap();
        assert_eq!(number_at(&edited, &e).unwrap(), 2.5e9);
        // Everything else, the comment after the value included, is where it was.
        assert_eq!(edited.lines().count(), DECK.lines().count());
        assert!(
            edited.contains("youngs_modulus = 2500000000.0   # Pa"),
            "{edited}"
        );
        for (a, b) in edited.lines().zip(DECK.lines()) {
            if !a.starts_with("youngs_modulus") {
                assert_eq!(a, b);
            }
        }
    }

    #[test]
    fn tables_arrays_and_inline_tables_are_walked() {
        let v = KeyPath::parse("boundary_conditions[1].value");
        assert_eq!(number_at(DECK, &v).unwrap(), -1.0);
        let r = KeyPath::parse("boundary_conditions[1].region.center[1]");
        let edited = set_number(DECK, &r, 0.3).unwrap();
        assert_eq!(number_at(&edited, &r).unwrap(), 0.3);
        assert_eq!(number_at(&edited, &v).unwrap(), -1.0);
    }

    #[test]
    fn integer_keys_stay_integers_and_bad_keys_are_named() {
        let seed = KeyPath::parse("material.seed");
        let edited = set_number(DECK, &seed, 8.6).unwrap();
        assert!(edited.contains("seed = 9"), "{edited}");
        let err = number_at(DECK, &KeyPath::parse("material.density")).unwrap_err();
        assert!(err.contains("no number at `material.density`"), "{err}");
        let err = number_at(DECK, &KeyPath::parse("material.type")).unwrap_err();
        assert!(err.contains("holds a string"), "{err}");
        let err = number_at(DECK, &KeyPath::parse("boundary_conditions[5].value")).unwrap_err();
        assert!(err.contains("no number"), "{err}");
        assert!(set_number(DECK, &seed, f64::NAN).is_err());
    }

    #[test]
    fn words_are_replaced_where_the_deck_has_a_word() {
        let kind = KeyPath::parse("material.type");
        let lps = DeckValue::Word("lps".into());
        let edited = set_value(DECK, &kind, &lps).unwrap();
        assert!(edited.contains("type = \"lps\""), "{edited}");
        assert_eq!(edited.lines().count(), DECK.lines().count());
        let err = settable(DECK, &KeyPath::parse("material.seed"), &lps).unwrap_err();
        assert!(err.contains("holds an integer, not a word"), "{err}");
        let err = settable(DECK, &kind, &DeckValue::Number(1.0)).unwrap_err();
        assert!(err.contains("holds a string, not a number"), "{err}");
        let err = settable(DECK, &KeyPath::parse("solver.method"), &lps).unwrap_err();
        assert!(err.contains("no word at `solver.method`"), "{err}");
    }
}
