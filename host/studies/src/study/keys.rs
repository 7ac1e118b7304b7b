//! Plant and controller keys: dotted paths into a plant's configuration as sim.toml writes
//! it, or into the controller's configuration (`trn_controller::Config`'s fields: a table's
//! key, a list's element by its index, or every element of a list or table: `*`), read and
//! set on its TOML tree. An unknown key is named with the keys there are; a value of another
//! type than the key's is refused (an integer where a number is expected is that number).

use toml::Value;

/// Which configuration keys name: how errors call the key and the tree's root.
#[derive(Debug, Clone, Copy)]
pub(super) struct KeySpace {
    what: &'static str,
    root: &'static str,
}

/// Keys into a plant's configuration (sim.toml).
pub(super) const PLANT: KeySpace = KeySpace {
    what: "plant key",
    root: "sim.toml",
};

/// Keys into the controller's configuration (`stage1.map_step`, `*.trial_secant`).
pub(super) const CONTROLLER: KeySpace = KeySpace {
    what: "controller key",
    root: "the controller configuration",
};

/// The value of a plant key (the first element's for `*`).
pub(super) fn get(tree: &Value, key: &str) -> std::result::Result<Value, String> {
    let mut tree = tree.clone();
    let mut found = None;
    walk_mut(&mut tree, key, PLANT, &mut |v| {
        found.get_or_insert_with(|| v.clone());
    })?;
    found.ok_or_else(|| format!("plant key `{key}` has no value"))
}

/// Sets a plant key (every element for `*`); the value's type must be the key's (an
/// integer where a number is expected is that number).
pub(super) fn set(
    tree: &mut Value,
    space: KeySpace,
    key: &str,
    value: &Value,
) -> std::result::Result<(), String> {
    let what = space.what;
    let mut err = None;
    let mut at = |slot: &mut Value| {
        let new = match (&*slot, value) {
            (Value::Float(_), Value::Integer(i)) => Value::Float(*i as f64),
            (Value::Table(_), _) => {
                err.get_or_insert(format!("{what} `{key}` is a table: set one of its keys"));
                return;
            }
            (old, new) if old.same_type(new) => new.clone(),
            (old, new) => {
                err.get_or_insert(format!(
                    "{what} `{key}` takes {} (got {} {new})",
                    old.type_str(),
                    new.type_str()
                ));
                return;
            }
        };
        *slot = new;
    };
    walk_mut(tree, key, space, &mut at)?;
    err.map_or(Ok(()), Err)
}

fn step_error(space: KeySpace, key: &str, path: &[String], part: &str, here: &Value) -> String {
    let at = if path.is_empty() {
        space.root.to_string()
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
    format!("unknown {} `{key}`: {at} has no `{part}`{keys}", space.what)
}

/// Whether `parts` name a value below `here` (`*` matching any element).
fn resolves(here: &Value, parts: &[&str]) -> bool {
    let Some((part, rest)) = parts.split_first() else {
        return true;
    };
    match here {
        Value::Table(t) if *part == "*" => t.values().any(|v| resolves(v, rest)),
        Value::Table(t) => t.get(*part).is_some_and(|v| resolves(v, rest)),
        Value::Array(a) if *part == "*" => a.iter().any(|v| resolves(v, rest)),
        Value::Array(a) => part
            .parse::<usize>()
            .ok()
            .and_then(|i| a.get(i))
            .is_some_and(|v| resolves(v, rest)),
        _ => false,
    }
}

/// Calls `f` on every value `key` names (a path of table keys, list indices and `*`).
fn walk_mut(
    tree: &mut Value,
    key: &str,
    space: KeySpace,
    f: &mut dyn FnMut(&mut Value),
) -> std::result::Result<(), String> {
    fn go(
        here: &mut Value,
        parts: &[&str],
        (key, space): (&str, KeySpace),
        path: &mut Vec<String>,
        f: &mut dyn FnMut(&mut Value),
    ) -> std::result::Result<(), String> {
        let Some((part, rest)) = parts.split_first() else {
            f(here);
            return Ok(());
        };
        let err = step_error(space, key, path, part, here);
        path.push(part.to_string());
        let r = match here {
            // every entry of a table that has the rest of the path (`*.trial_secant`: both
            // stages of the controller), at least one
            Value::Table(t) if *part == "*" => {
                let mut found = false;
                for (k, v) in t.iter_mut().filter(|(_, v)| resolves(v, rest)) {
                    *path.last_mut().expect("pushed") = k.to_string();
                    found = true;
                    go(v, rest, (key, space), path, f)?;
                }
                if found {
                    Ok(())
                } else {
                    Err(err)
                }
            }
            Value::Table(t) => match t.get_mut(*part) {
                Some(v) => go(v, rest, (key, space), path, f),
                None => Err(err),
            },
            Value::Array(a) if *part == "*" => a.iter_mut().enumerate().try_for_each(|(i, v)| {
                // errors below name the element
                *path.last_mut().expect("pushed") = i.to_string();
                go(v, rest, (key, space), path, f)
            }),
            Value::Array(a) => match part.parse::<usize>().ok().and_then(|i| a.get_mut(i)) {
                Some(v) => go(v, rest, (key, space), path, f),
                None => Err(err),
            },
            _ => Err(err),
        };
        path.pop();
        r
    }
    if key.is_empty() {
        return Err(format!("an empty {}", space.what));
    }
    let parts: Vec<&str> = key.split('.').collect();
    go(tree, &parts, (key, space), &mut Vec::new(), f)
}
