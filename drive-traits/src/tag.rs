//! Tags: the names under which parts are saved in files (typetag), declared by each saved
//! type so that the registries can check them when a part is registered.

use serde::de::DeserializeOwned;

/// The tag a saved type is written under: the `name` of its `#[typetag::serde(name = ...)]`
/// impl, repeated as a constant so that a registry can check it when the part is registered
/// (typetag itself only notices a duplicate when a file is loaded).
///
/// ```
/// use drive_traits::{BodyVelocity, SlipModel, Tagged};
/// use serde::{Deserialize, Serialize};
///
/// /// A user's slip model: a fixed fraction of the commanded velocity is lost.
/// #[derive(Debug, Clone, Serialize, Deserialize)]
/// struct Fraction { lost: f64 }
///
/// #[typetag::serde(name = "fraction")]
/// impl SlipModel for Fraction {
///     fn slip(&self, f: &BodyVelocity) -> BodyVelocity { f * self.lost }
///     fn clone_box(&self) -> Box<dyn SlipModel> { Box::new(self.clone()) }
/// }
/// impl Tagged for Fraction { const TAG: &'static str = "fraction"; }
///
/// let saved = serde_json::to_string(&Fraction { lost: 0.1 } as &dyn SlipModel).unwrap();
/// assert_eq!(saved, r#"{"type":"fraction","lost":0.1}"#);
/// ```
pub trait Tagged {
    /// The tag (the typetag name of the type's impl).
    const TAG: &'static str;
}

/// What typetag knows of a tag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TagProbe {
    /// Exactly one linked type is saved under the tag.
    Unique,
    /// No linked type is saved under it.
    Missing,
    /// Two or more linked types are saved under it.
    Shared,
}

/// The tag of a part's saved type, with what is needed to check it.
#[derive(Clone)]
pub struct PartTag {
    /// The trait the type is saved as (`Powertrain`, `SlipModel`, ...).
    pub family: &'static str,
    /// The tag.
    pub tag: String,
    /// The Rust type, for messages.
    pub type_name: String,
    probe: fn(&str) -> TagProbe,
}

impl std::fmt::Debug for PartTag {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PartTag")
            .field("family", &self.family)
            .field("tag", &self.tag)
            .field("type_name", &self.type_name)
            .finish()
    }
}

impl PartTag {
    /// The tag of type `S`, saved as the trait object `B` (for instance
    /// `Box<dyn Powertrain>`), family named `family` in messages.
    pub fn of<S: Tagged, B: DeserializeOwned>(family: &'static str) -> Self {
        PartTag {
            family,
            tag: S::TAG.to_string(),
            type_name: std::any::type_name::<S>().to_string(),
            probe: probe_tag::<B>,
        }
    }

    /// A tag read from a value (a vehicle instance), saved as the trait object `B`.
    pub fn named<B: DeserializeOwned>(
        family: &'static str,
        tag: String,
        type_name: String,
    ) -> Self {
        PartTag {
            family,
            tag,
            type_name,
            probe: probe_tag::<B>,
        }
    }

    /// What typetag knows of this tag.
    pub fn probe(&self) -> TagProbe {
        (self.probe)(&self.tag)
    }
}

/// Asks typetag's registry of the trait object `B` about `tag`, by reading `{"type": tag}`:
/// an unknown name, a duplicate, or a type that was found (and then reads or misses its
/// fields).
fn probe_tag<B: DeserializeOwned>(tag: &str) -> TagProbe {
    match serde_json::from_value::<B>(serde_json::json!({ "type": tag })) {
        Ok(_) => TagProbe::Unique,
        Err(e) => {
            let message = e.to_string();
            if message.contains("non-unique tag") {
                TagProbe::Shared
            } else if message.contains("unknown variant") {
                TagProbe::Missing
            } else {
                TagProbe::Unique
            }
        }
    }
}
