//! Run data written as text: the typed columns of `results.csv` and `histories.csv` (problem
//! class, family, solver specification, budget name) are written with their `Display` form and
//! read back with their `FromStr`, so a CSV cell is parsed once, where the row is read, and a
//! cell that names nothing known is an error on that row rather than an empty table cell later.

/// Implement `Serialize` and `Deserialize` for a type through its `Display` and `FromStr`.
macro_rules! serde_as_text {
    ($t:ty) => {
        impl serde::Serialize for $t {
            fn serialize<S: serde::Serializer>(&self, out: S) -> Result<S::Ok, S::Error> {
                out.collect_str(self)
            }
        }

        impl<'de> serde::Deserialize<'de> for $t {
            fn deserialize<D: serde::Deserializer<'de>>(input: D) -> Result<Self, D::Error> {
                let text = <String as serde::Deserialize>::deserialize(input)?;
                text.parse().map_err(serde::de::Error::custom)
            }
        }
    };
}

pub(crate) use serde_as_text;
