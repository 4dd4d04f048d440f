//! Decoding checkpoint parts straight into the structures that hold them. `postcard`'s
//! `take_from_bytes` builds a value and returns it, so a restored planner was built in a
//! temporary and then moved field by field into place, each fixed-capacity list copied whole
//! (its capacity, not its length) more than once. The seeds here read the same bytes into the
//! destination: [`VecInto`] accepts exactly what `heapless::Vec`'s own `Deserialize` accepts
//! (the same items, an error on one item over the capacity), and [`take_in_place`] leaves the
//! bytes after the part as `take_from_bytes` does. On error the destination holds a part of
//! what was read: callers reset it.
use core::fmt;

use heapless::Vec;
use serde::de::{DeserializeSeed, Deserializer, Error, SeqAccess, Visitor};
use serde::Deserialize;

/// A list decoded into the `Vec` it will live in (cleared first).
pub(crate) struct VecInto<'a, T, const N: usize>(pub &'a mut Vec<T, N>);

impl<'de, T: Deserialize<'de>, const N: usize> DeserializeSeed<'de> for VecInto<'_, T, N> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<(), D::Error> {
        deserializer.deserialize_seq(self)
    }
}

impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for VecInto<'_, T, N> {
    type Value = ();

    fn expecting(&self, formatter: &mut fmt::Formatter<'_>) -> fmt::Result {
        formatter.write_str("a sequence")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let items = self.0;
        items.clear();
        while let Some(item) = seq.next_element()? {
            if items.push(item).is_err() {
                return Err(A::Error::invalid_length(N + 1, &"a sequence"));
            }
        }
        Ok(())
    }
}

/// The next field of a struct read as a sequence, decoded by `seed` into its place; `index`
/// names the field in the error when the sequence ends early.
pub(crate) fn field_into<'de, A, S>(seq: &mut A, seed: S, index: usize) -> Result<(), A::Error>
where
    A: SeqAccess<'de>,
    S: DeserializeSeed<'de, Value = ()>,
{
    seq.next_element_seed(seed)?
        .ok_or_else(|| A::Error::invalid_length(index, &"more fields"))
}

/// The next field of a struct read as a sequence, as a (small) value.
pub(crate) fn field<'de, A, T>(seq: &mut A, index: usize) -> Result<T, A::Error>
where
    A: SeqAccess<'de>,
    T: Deserialize<'de>,
{
    seq.next_element()?
        .ok_or_else(|| A::Error::invalid_length(index, &"more fields"))
}

/// Decodes one part off the front of `bytes` with `seed` (which writes it where it belongs);
/// the bytes after it, or None if it does not decode.
pub(crate) fn take_in_place<'de, S>(bytes: &'de [u8], seed: S) -> Option<&'de [u8]>
where
    S: DeserializeSeed<'de, Value = ()>,
{
    let mut deserializer = postcard::Deserializer::from_bytes(bytes);
    seed.deserialize(&mut deserializer).ok()?;
    deserializer.finalize().ok()
}
