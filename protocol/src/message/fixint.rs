//! Integers wider than a byte: fixed-width little endian on the wire (postcard's
//! `fixint::le`), plain numbers in a format for people (JSON from `trn decode --format json`,
//! the Python binding's dicts), where postcard's wrapper would show `seq: 51` as the bytes
//! `[51, 0]`. The choice is the format's own `is_human_readable`: postcard's is false, so
//! the wire's bytes are exactly `postcard::fixint::le`'s.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// An integer type with a fixed-width little-endian wire form.
pub trait FixedLe: Copy + Serialize + for<'de> Deserialize<'de> {
    /// Serialised as fixed-width little endian.
    fn serialize_le<S: Serializer>(self, s: S) -> Result<S::Ok, S::Error>;
    /// Deserialised from fixed-width little endian.
    fn deserialize_le<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error>;
}

macro_rules! fixed_le {
    ($($t:ty),*) => {$(
        impl FixedLe for $t {
            fn serialize_le<S: Serializer>(self, s: S) -> Result<S::Ok, S::Error> {
                postcard::fixint::le::serialize(&self, s)
            }
            fn deserialize_le<'de, D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                postcard::fixint::le::deserialize(d)
            }
        }
    )*};
}

fixed_le!(u16, u32, u64);

/// `#[serde(with = "fixint")]`'s serialiser.
pub fn serialize<S: Serializer, T: FixedLe>(v: &T, s: S) -> Result<S::Ok, S::Error> {
    if s.is_human_readable() {
        v.serialize(s)
    } else {
        v.serialize_le(s)
    }
}

/// `#[serde(with = "fixint")]`'s deserialiser.
pub fn deserialize<'de, D: Deserializer<'de>, T: FixedLe>(d: D) -> Result<T, D::Error> {
    if d.is_human_readable() {
        T::deserialize(d)
    } else {
        T::deserialize_le(d)
    }
}
