//! A message's fields as JSON, read from its `Debug` form: every message type derives
//! `Debug`, which prints each field's value as Rust holds it (integers as integers, which
//! the serde form does not: the wire's fixed-width integers serialise as byte arrays), so a
//! kind added to the protocol is covered without a change here.
//!
//! The grammar is the subset `#[derive(Debug)]` prints for plain data: `Name { field:
//! value, .. }` (an object), `Name(value)` (the value; several: an array), `[..]`, numbers
//! (`NaN` and infinities as `null`), `true`/`false`, a bare name (an enum variant: its
//! name; `None`: `null`) and quoted strings.

use serde_json::{Map, Value};

/// The JSON of a `Debug` form; `None` when it is not of the grammar above.
pub fn from_debug(s: &str) -> Option<Value> {
    let mut p = Parser {
        s: s.as_bytes(),
        i: 0,
    };
    let v = p.value()?;
    p.ws();
    (p.i == p.s.len()).then_some(v)
}

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
}

impl Parser<'_> {
    fn ws(&mut self) {
        while self.s.get(self.i).is_some_and(|c| c.is_ascii_whitespace()) {
            self.i += 1;
        }
    }

    fn peek(&mut self) -> Option<u8> {
        self.ws();
        self.s.get(self.i).copied()
    }

    fn eat(&mut self, c: u8) -> bool {
        if self.peek() == Some(c) {
            self.i += 1;
            true
        } else {
            false
        }
    }

    fn word(&mut self) -> &str {
        self.ws();
        let start = self.i;
        while self
            .s
            .get(self.i)
            .is_some_and(|c| c.is_ascii_alphanumeric() || matches!(c, b'_' | b'.' | b'-' | b'+'))
        {
            self.i += 1;
        }
        std::str::from_utf8(&self.s[start..self.i]).unwrap_or("")
    }

    /// `items` separated by commas up to `close` (a trailing comma allowed).
    fn list(&mut self, close: u8) -> Option<Vec<Value>> {
        let mut out = Vec::new();
        while !self.eat(close) {
            out.push(self.value()?);
            if !self.eat(b',') {
                return self.eat(close).then_some(out);
            }
        }
        Some(out)
    }

    fn value(&mut self) -> Option<Value> {
        match self.peek()? {
            b'[' => {
                self.i += 1;
                self.list(b']').map(Value::Array)
            }
            b'"' => self.string(),
            _ => {
                let w = self.word().to_string();
                if w.is_empty() {
                    return None;
                }
                if w.starts_with(|c: char| c.is_ascii_digit() || c == '-') {
                    return number(&w);
                }
                match (w.as_str(), self.peek()) {
                    ("true", _) => Some(Value::Bool(true)),
                    ("false", _) => Some(Value::Bool(false)),
                    ("NaN" | "inf", _) => Some(Value::Null),
                    (_, Some(b'{')) => {
                        self.i += 1;
                        let mut m = Map::new();
                        loop {
                            if self.eat(b'}') {
                                break;
                            }
                            let k = self.word().to_string();
                            if k.is_empty() || !self.eat(b':') {
                                return None;
                            }
                            m.insert(k, self.value()?);
                            if !self.eat(b',') && self.peek() != Some(b'}') {
                                return None;
                            }
                        }
                        Some(Value::Object(m))
                    }
                    (_, Some(b'(')) => {
                        self.i += 1;
                        let mut items = self.list(b')')?;
                        Some(if items.len() == 1 {
                            items.remove(0)
                        } else {
                            Value::Array(items)
                        })
                    }
                    ("None", _) => Some(Value::Null),
                    _ => Some(Value::String(w)),
                }
            }
        }
    }

    fn string(&mut self) -> Option<Value> {
        self.i += 1;
        let mut out = String::new();
        while let Some(&c) = self.s.get(self.i) {
            self.i += 1;
            match c {
                b'"' => return Some(Value::String(out)),
                b'\\' => {
                    let e = *self.s.get(self.i)?;
                    self.i += 1;
                    out.push(match e {
                        b'n' => '\n',
                        b't' => '\t',
                        other => other as char,
                    });
                }
                _ => out.push(c as char),
            }
        }
        None
    }
}

fn number(w: &str) -> Option<Value> {
    if w == "-inf" {
        return Some(Value::Null);
    }
    if let Ok(i) = w.parse::<i64>() {
        return Some(Value::from(i));
    }
    if let Ok(u) = w.parse::<u64>() {
        return Some(Value::from(u));
    }
    let f: f64 = w.parse().ok()?;
    Some(serde_json::Number::from_f64(f).map_or(Value::Null, Value::Number))
}
