//! Plant keys: dotted paths into a plant's configuration as sim.toml writes it (a table's
//! key, a list's element by its index, or every element: `*`), read and set on its TOML
//! tree. An unknown key is named with the keys there are; a value of another type than the
//! key's is refused (an integer where a number is expected is that number).

use toml::Value;

/// The value of a plant key (the first element's for `*`).
pub(super) fn get(tree: &Value, key: &str) -> std::result::Result<Value, String> {
    let mut tree = tree.clone();
    let mut found = None;
    walk_mut(&mut tree, key, &mut |v| {
        found.get_or_insert_with(|| v.clone());
    })?;
    found.ok_or_else(|| format!("plant key `{key}` has no value"))
}

/// Sets a plant key (every element for `*`); the value's type must be the key's (an
/// integer where a number is expected is that number).
pub(super) fn set(tree: &mut Value, key: &str, value: &Value) -> std::result::Result<(), String> {
    let mut err = None;
    let mut at = |slot: &mut Value| {
        let new = match (&*slot, value) {
            (Value::Float(_), Value::Integer(i)) => Value::Float(*i as f64),
            (Value::Table(_), _) => {
                err.get_or_insert(format!("plant key `{key}` is a table: set one of its keys"));
                return;
            }
            (old, new) if old.same_type(new) => new.clone(),
            (old, new) => {
                err.get_or_insert(format!(
                    "plant key `{key}` takes {} (got {} {new})",
                    old.type_str(),
                    new.type_str()
                ));
                return;
            }
        };
        *slot = new;
    };
    walk_mut(tree, key, &mut at)?;
    err.map_or(Ok(()), Err)
}

fn step_error(key: &str, path: &[String], part: &str, here: &Value) -> String {
    let at = if path.is_empty() {
        "sim.toml".to_string()
    } else {
        format!("`{}`", path.join("."))
    };
    let keys = match here {
        Value::Table(t) => format!(
            " (its keys: {})",
            t.keys().cloned().collect::<Vec<_>>().join(", ")
        ),
        Value::Array(a) => format!(" (a list of {}: an index 0..{} or *)", a.len(), a.len()),
        _ => String::new(),
    };
    format!("unknown plant key `{key}`: {at} has no `{part}`{keys}")
}

/// Calls `f` on every value `key` names (a path of table keys, list indices and `*`).
fn walk_mut(
    tree: &mut Value,
    key: &str,
    f: &mut dyn FnMut(&mut Value),
) -> std::result::Result<(), String> {
    fn go(
        here: &mut Value,
        parts: &[&str],
        key: &str,
        path: &mut Vec<String>,
        f: &mut dyn FnMut(&mut Value),
    ) -> std::result::Result<(), String> {
        let Some((part, rest)) = parts.split_first() else {
            f(here);
            return Ok(());
        };
        let err = step_error(key, path, part, here);
        path.push(part.to_string());
        let r = match here {
            Value::Table(t) => match t.get_mut(*part) {
                Some(v) => go(v, rest, key, path, f),
                None => Err(err),
            },
            Value::Array(a) if *part == "*" => a.iter_mut().enumerate().try_for_each(|(i, v)| {
                // errors below name the element
                *path.last_mut().expect("pushed") = i.to_string();
                go(v, rest, key, path, f)
            }),
            Value::Array(a) => match part.parse::<usize>().ok().and_then(|i| a.get_mut(i)) {
                Some(v) => go(v, rest, key, path, f),
                None => Err(err),
            },
            _ => Err(err),
        };
        path.pop();
        r
    }
    if key.is_empty() {
        return Err("an empty plant key".into());
    }
    let parts: Vec<&str> = key.split('.').collect();
    go(tree, &parts, key, &mut Vec::new(), f)
}
