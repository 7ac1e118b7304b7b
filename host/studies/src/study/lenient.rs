//! Reading a report back from its JSON: a float that is `null` is NaN.
//!
//! A report writes a mean over nothing as NaN, which JSON cannot hold: `serde_json` writes
//! it as `null`, and refuses `null` for an `f32` when reading it back. A study reads every
//! run's report back (to resume, to merge shards), so [`from_value`] deserializes from a
//! [`serde_json::Value`] the way `serde_json` does, with one difference: `null` where a
//! float is expected is NaN (and `null` where an `Option` is expected stays `None`).

use serde::de::{self, DeserializeOwned, IntoDeserializer, Visitor};
use serde_json::{Map, Value};

/// The error of a lenient read.
type Error = serde_json::Error;

/// Deserializes `T` from `value`, reading `null` as NaN where `T` has a float.
pub fn from_value<T: DeserializeOwned>(value: Value) -> Result<T, Error> {
    T::deserialize(Lenient(value))
}

/// A JSON value as a deserializer that reads `null` floats as NaN.
struct Lenient(Value);

impl Lenient {
    fn float<'de, V: Visitor<'de>>(self, visitor: V, f32_: bool) -> Result<V::Value, Error> {
        match self.0 {
            Value::Null if f32_ => visitor.visit_f32(f32::NAN),
            Value::Null => visitor.visit_f64(f64::NAN),
            other => de::Deserializer::deserialize_any(other, visitor),
        }
    }
}

impl<'de> de::Deserializer<'de> for Lenient {
    type Error = Error;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        match self.0 {
            Value::Array(items) => visitor.visit_seq(Seq(items.into_iter())),
            Value::Object(map) => visitor.visit_map(Fields::new(map)),
            other => de::Deserializer::deserialize_any(other, visitor),
        }
    }

    fn deserialize_f32<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        self.float(visitor, true)
    }

    fn deserialize_f64<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        self.float(visitor, false)
    }

    fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        match self.0 {
            Value::Null => visitor.visit_none(),
            other => visitor.visit_some(Lenient(other)),
        }
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value, Error> {
        visitor.visit_newtype_struct(self)
    }

    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, Error> {
        match self.0 {
            Value::String(s) => visitor.visit_enum(s.into_deserializer()),
            Value::Object(map) if map.len() == 1 => {
                let (k, v) = map.into_iter().next().expect("one entry");
                visitor.visit_enum(Variant(k, v))
            }
            other => Err(de::Error::invalid_type(
                unexpected(&other),
                &"an enum variant",
            )),
        }
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 char str string bytes byte_buf unit
        unit_struct seq tuple tuple_struct map struct identifier ignored_any
    }
}

fn unexpected(v: &Value) -> de::Unexpected<'_> {
    match v {
        Value::Null => de::Unexpected::Unit,
        Value::Bool(b) => de::Unexpected::Bool(*b),
        Value::Number(_) => de::Unexpected::Other("a number"),
        Value::String(s) => de::Unexpected::Str(s),
        Value::Array(_) => de::Unexpected::Seq,
        Value::Object(_) => de::Unexpected::Map,
    }
}

/// The items of an array, each lenient.
struct Seq(std::vec::IntoIter<Value>);

impl<'de> de::SeqAccess<'de> for Seq {
    type Error = Error;

    fn next_element_seed<T: de::DeserializeSeed<'de>>(
        &mut self,
        seed: T,
    ) -> Result<Option<T::Value>, Error> {
        self.0
            .next()
            .map(|v| seed.deserialize(Lenient(v)))
            .transpose()
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.0.len())
    }
}

/// The entries of an object, each value lenient.
struct Fields {
    entries: serde_json::map::IntoIter,
    value: Option<Value>,
}

impl Fields {
    fn new(map: Map<String, Value>) -> Fields {
        Fields {
            entries: map.into_iter(),
            value: None,
        }
    }
}

impl<'de> de::MapAccess<'de> for Fields {
    type Error = Error;

    fn next_key_seed<K: de::DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, Error> {
        match self.entries.next() {
            Some((k, v)) => {
                self.value = Some(v);
                seed.deserialize(k.into_deserializer()).map(Some)
            }
            None => Ok(None),
        }
    }

    fn next_value_seed<V: de::DeserializeSeed<'de>>(&mut self, seed: V) -> Result<V::Value, Error> {
        let v = self
            .value
            .take()
            .ok_or_else(|| de::Error::custom("a value without its key"))?;
        seed.deserialize(Lenient(v))
    }
}

/// An externally tagged enum variant (`{"Name": value}`).
struct Variant(String, Value);

impl<'de> de::EnumAccess<'de> for Variant {
    type Error = Error;
    type Variant = Lenient;

    fn variant_seed<V: de::DeserializeSeed<'de>>(
        self,
        seed: V,
    ) -> Result<(V::Value, Lenient), Error> {
        let name = seed.deserialize(self.0.into_deserializer())?;
        Ok((name, Lenient(self.1)))
    }
}

impl<'de> de::VariantAccess<'de> for Lenient {
    type Error = Error;

    fn unit_variant(self) -> Result<(), Error> {
        match self.0 {
            Value::Null => Ok(()),
            other => Err(de::Error::invalid_type(
                unexpected(&other),
                &"a unit variant",
            )),
        }
    }

    fn newtype_variant_seed<T: de::DeserializeSeed<'de>>(self, seed: T) -> Result<T::Value, Error> {
        seed.deserialize(self)
    }

    fn tuple_variant<V: Visitor<'de>>(self, _len: usize, visitor: V) -> Result<V::Value, Error> {
        de::Deserializer::deserialize_any(self, visitor)
    }

    fn struct_variant<V: Visitor<'de>>(
        self,
        _fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, Error> {
        de::Deserializer::deserialize_any(self, visitor)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::{Deserialize, Serialize};

    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    enum Bus {
        InProc,
        SocketCan(String),
        Shaped { w: f32 },
    }

    #[derive(Debug, Clone, Serialize, Deserialize)]
    struct Sample {
        mean: f32,
        wide: f64,
        curve: Vec<f32>,
        pair: (f32, f32),
        maybe: Option<f32>,
        name: String,
        n: usize,
        buses: Vec<Bus>,
        inner: Option<Box<Sample>>,
    }

    /// NaN goes out as `null` and comes back as NaN, wherever a float is (a field, a list,
    /// a tuple, a nested struct); `None` stays `None`; enums of every shape survive.
    #[test]
    fn null_floats_come_back_as_nan_and_everything_else_as_it_was() {
        let inner = Sample {
            mean: 1.5,
            wide: f64::NAN,
            curve: vec![],
            pair: (f32::NAN, 2.0),
            maybe: Some(f32::NAN),
            name: "in".into(),
            n: 0,
            buses: vec![Bus::InProc],
            inner: None,
        };
        let s = Sample {
            mean: f32::NAN,
            wide: 0.1,
            curve: vec![1.0, f32::NAN, 3.25],
            pair: (0.5, f32::NAN),
            maybe: None,
            name: "x".into(),
            n: 7,
            buses: vec![Bus::SocketCan("vcan0".into()), Bus::Shaped { w: f32::NAN }],
            inner: Some(Box::new(inner)),
        };
        let text = serde_json::to_string(&s).unwrap();
        assert!(text.contains("\"mean\":null"), "{text}");
        assert!(
            serde_json::from_str::<Sample>(&text).is_err(),
            "serde_json alone refuses a null float: this module would not be needed"
        );
        let back: Sample = from_value(serde_json::from_str(&text).unwrap()).unwrap();
        assert!(back.mean.is_nan() && back.pair.1.is_nan() && back.curve[1].is_nan());
        assert_eq!((back.wide, back.pair.0, back.curve[2]), (0.1, 0.5, 3.25));
        assert_eq!(back.maybe, None);
        assert_eq!((back.name.as_str(), back.n), ("x", 7));
        assert_eq!(back.buses[0], Bus::SocketCan("vcan0".into()));
        assert!(matches!(back.buses[1], Bus::Shaped { w } if w.is_nan()));
        let inner = back.inner.unwrap();
        assert!(inner.wide.is_nan() && inner.pair.0.is_nan());
        // Some(NaN) is written as null: it reads back as None (JSON cannot tell them apart)
        assert_eq!(inner.maybe, None);
        assert_eq!(inner.buses, vec![Bus::InProc]);
        // the re-serialized text is the text read
        assert_eq!(
            serde_json::to_string(
                &from_value::<Sample>(serde_json::from_str(&text).unwrap()).unwrap()
            )
            .unwrap(),
            text
        );
    }

    /// A wrong type is still an error, not a NaN.
    #[test]
    fn a_wrong_type_is_an_error() {
        let v = serde_json::json!({"mean": "wide"});
        #[derive(Debug, Deserialize)]
        #[allow(dead_code)]
        struct M {
            mean: f32,
        }
        assert!(from_value::<M>(v).is_err());
    }
}
