//! The interface of a model type ([`ModelType`]): its name, its keys (the fields of its serde
//! struct, read off the struct by [`struct_fields`]: one list, no copy to keep in step) and its
//! validation into nodes and a [`SceneModel`] ([`Validated`]). The registry of linpd's types is
//! [`super::registry`]; a type defined outside linpd (a test's) implements this trait only.

use super::SceneModel;
use crate::nodes::Nodes;
pub use crate::validate::Context;
use crate::ProblemError;
use serde::de::{self, Visitor};
use serde::Deserialize;

/// One model type of the scene format.
pub trait ModelType: Sync {
    /// `model.type` in scene files.
    fn name(&self) -> &'static str;
    /// The fields of its `model` struct, `type` included ([`struct_fields`]).
    fn fields(&self) -> &'static [&'static str];
    /// Validates a scene of this type: its keys, its nodes and its model (the scene's
    /// constraints and loads are validated on those nodes afterwards, and handed to the model:
    /// [`SceneModel::bind`]).
    fn validate(&self, cx: &Context) -> Result<Validated, ProblemError>;
}

/// What a model type's validation returns.
#[derive(Debug)]
pub struct Validated {
    /// The nodes (a lattice, a point cloud, a level's nodes).
    pub nodes: Nodes,
    /// The model.
    pub model: Box<dyn SceneModel>,
}

/// The helpers a model type defined outside linpd needs ([`crate::validate`]).
impl Context<'_> {
    /// The scene's dimension (checked to be 1, 2 or 3).
    pub fn dim(&self) -> usize {
        self.raw.dimension
    }

    /// The `model` section as the type's own struct `T`: errors carry the JSON path under
    /// `model` and the line and column in the scene file.
    pub fn model_keys<T: serde::de::DeserializeOwned>(&self) -> Result<T, ProblemError> {
        self.raw.model.parse()
    }

    /// The scene's lattice (`grid`, `body`), checked against the horizon and against the
    /// memory of `path` before anything per node is allocated.
    pub fn lattice(&self, horizon: f64, path: crate::memory::Path) -> Result<linpd_core::Grid, ProblemError> {
        crate::validate::lattice(self, horizon, path)
    }

    /// A bond micromodulus from its keys (`model.micromodulus`, `model.plane`,
    /// `model.partial_volume`), validated for the scene's dimension.
    pub fn micromodulus(
        &self,
        horizon: f64,
        micromodulus: Option<&crate::raw::RawMicromodulus>,
        plane: Option<crate::raw::RawPlane>,
        partial_volume: bool,
    ) -> Result<linpd_core::Micromodulus, ProblemError> {
        crate::validate::bond_micromodulus(self.dim(), horizon, micromodulus, plane, partial_volume)
    }
}

/// The field names of the struct `T` derives `Deserialize` for (every field a `#[serde(deny_unknown_fields)]`
/// struct accepts), read off the derive: serde passes them to `deserialize_struct`.
pub fn struct_fields<T: for<'de> Deserialize<'de>>() -> &'static [&'static str] {
    let mut fields = None;
    let _ = T::deserialize(Introspect(&mut fields));
    fields.unwrap_or(&[])
}

/// A deserializer that only records the fields a struct asks for.
struct Introspect<'a>(&'a mut Option<&'static [&'static str]>);

impl<'de> de::Deserializer<'de> for Introspect<'_> {
    type Error = de::value::Error;

    fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Self::Error> {
        Err(de::Error::custom("not a struct"))
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        _visitor: V,
    ) -> Result<V::Value, Self::Error> {
        *self.0 = Some(fields);
        Err(de::Error::custom("fields recorded"))
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf option
        unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier ignored_any
    }
}
