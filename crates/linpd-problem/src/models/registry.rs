//! The registry of model types: the one place that maps `model.type` to the module that owns
//! it. A model type ([`ModelType`]) names itself, lists its keys (the fields of its serde
//! struct, read off the struct by [`struct_fields`]: one list, no copy to keep in step) and
//! validates a scene into its nodes and a [`SceneModel`].
//!
//! A key of `model` that the scene's type does not take is an error naming the key, the type
//! and the types that do take it; an unknown type is an error listing the registered ones.

use super::{blend_1d, bond, coarsened, lps, SceneModel};
use crate::problem::Nodes;
use crate::raw::{RawModelJson, RawProblem};
use crate::ProblemError;
use serde::de::{self, Visitor};
use serde::Deserialize;
use std::path::Path;

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

/// A scene being validated: the parsed mirror and the directory its file names start at.
pub struct Context<'a> {
    /// The serde mirror.
    pub raw: &'a RawProblem,
    /// Relative file names in the scene start here (the scene file's directory).
    pub base_dir: &'a Path,
}

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
        crate::problem::lattice(self, horizon, path)
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
        crate::problem::bond_micromodulus(self.dim(), horizon, micromodulus, plane, partial_volume)
    }
}

/// The model types a scene may name.
pub struct Registry {
    types: Vec<&'static dyn ModelType>,
}

static BUILTIN: [&dyn ModelType; 5] = [&bond::BOND, &blend_1d::BLEND, &blend_1d::CE, &lps::LPS, &coarsened::COARSENED];

impl Default for Registry {
    /// linpd's model types.
    fn default() -> Self {
        Registry { types: BUILTIN.to_vec() }
    }
}

impl Registry {
    /// This registry and `t` (a model type defined outside linpd, e.g. in a test).
    pub fn with(mut self, t: &'static dyn ModelType) -> Self {
        self.types.push(t);
        self
    }

    /// The registered names, in order.
    pub fn names(&self) -> Vec<&'static str> {
        self.types.iter().map(|t| t.name()).collect()
    }

    /// The type named `name`.
    pub fn get(&self, name: &str) -> Option<&'static dyn ModelType> {
        self.types.iter().copied().find(|t| t.name() == name)
    }

    /// The keys `t` takes besides `type`.
    fn keys(t: &dyn ModelType) -> impl Iterator<Item = &'static str> {
        t.fields().iter().copied().filter(|&k| k != "type")
    }

    /// The type of a `model` section, after checking that every key given is one it takes.
    pub(crate) fn resolve(&self, model: &RawModelJson) -> Result<&'static dyn ModelType, ProblemError> {
        let head: ModelHead = model.parse()?;
        let Some(t) = self.get(&head.kind) else {
            let expected: Vec<String> = self.names().iter().map(|n| format!("`{n}`")).collect();
            return Err(ProblemError::invalid(
                "model.type",
                format!("unknown variant `{}`, expected one of {}", head.kind, expected.join(", ")),
            ));
        };
        for key in head.keys.keys() {
            if key == "type" || Self::keys(t).any(|k| k == key) {
                continue;
            }
            let takers: Vec<&str> =
                self.types.iter().filter(|u| Self::keys(**u).any(|k| k == key)).map(|u| u.name()).collect();
            if takers.is_empty() {
                let expected: Vec<String> = Self::keys(t).map(|k| format!("`{k}`")).collect();
                return Err(ProblemError::invalid(
                    format!("model.{key}"),
                    format!("unknown field `{key}`, expected one of `type`, {}", expected.join(", ")),
                ));
            }
            let takers = match takers.as_slice() {
                [] => unreachable!("checked above"),
                [one] => format!("only {one} models take it"),
                [init @ .., last] => format!("only {} and {last} models take it", init.join(", ")),
            };
            return Err(ProblemError::invalid(
                format!("model.{key}"),
                format!("not a key of {} models ({takers}); remove it", t.name()),
            ));
        }
        Ok(t)
    }
}

/// The `type` of a `model` section and the keys given with it.
#[derive(Deserialize)]
struct ModelHead {
    #[serde(rename = "type")]
    kind: String,
    #[serde(flatten)]
    keys: std::collections::BTreeMap<String, de::IgnoredAny>,
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
