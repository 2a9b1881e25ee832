//! Open registries: every kind of part (vehicles, powertrains, slip learners, baselines,
//! samplers, terrains, robots) is found by name in a [`Registry`], with one shape and one
//! error type ([`RegistryError`]).
//!
//! A part whose fitted type is saved in files declares the tag it is saved under
//! ([`Tagged`](crate::Tagged)); registering it checks that the tag is the one its
//! `#[typetag::serde(name = ...)]` gives and that no other part uses it, so that a collision
//! is an error at registration, naming both parts, not when a file is loaded.

use crate::InvalidPart;
use crate::PartTag;
use std::sync::Arc;
use thiserror::Error;

/// Why a registration or a lookup failed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RegistryError {
    /// The name is empty or holds characters that break model names (`slip+powertrain`),
    /// CSV files and command-line lists.
    #[error(
        "'{name}' is not a usable {kind} name (non-empty; ASCII letters, digits, '-' and '_')"
    )]
    BadName {
        /// Kind of part.
        kind: &'static str,
        /// The name given.
        name: String,
    },
    /// The name is already taken in this registry.
    #[error("a {kind} named '{name}' is already registered")]
    Duplicate {
        /// Kind of part.
        kind: &'static str,
        /// The name given.
        name: String,
    },
    /// No part of that name.
    #[error("unknown {kind} '{name}' (the {kind}s are: {known})")]
    Unknown {
        /// Kind of part.
        kind: &'static str,
        /// The name asked for.
        name: String,
        /// The registered names, comma-separated.
        known: String,
    },
    /// A model name whose parts do not fit together (a powertrain given to a learner that
    /// takes none, ...).
    #[error("model '{name}': {reason}")]
    BadModel {
        /// The model name given.
        name: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A part registered under another name than the tag its files are saved with (a
    /// vehicle: sidecars, robot files and model files name it by its tag).
    #[error("the {kind} registered as '{name}' is saved in files as '{tag}': register it under '{tag}' (one name per part)")]
    NameIsNotTag {
        /// Kind of part.
        kind: &'static str,
        /// The name it was registered under.
        name: String,
        /// The tag its type is saved with.
        tag: String,
    },
    /// A part that breaks a rule of its kind (a vehicle of four input axes).
    #[error("the {kind} '{name}' cannot be registered: {reason}")]
    BadPart {
        /// Kind of part.
        kind: &'static str,
        /// The name given.
        name: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A part registered for another that is not registered (a simulator for a vehicle).
    #[error("a {kind} is registered for the {of} '{name}', which is not a registered {of} (the {of}s are: {known})")]
    Orphan {
        /// Kind of part.
        kind: &'static str,
        /// What it is registered for.
        of: &'static str,
        /// The name it was registered under.
        name: String,
        /// The registered names of `of`, comma-separated.
        known: String,
    },
    /// Two registered parts of different types are saved under the same tag.
    #[error("{0}")]
    TagCollision(Box<TagCollision>),
    /// Another type linked into the program (not registered here) has the same tag.
    #[error("{kind} '{name}': the tag '{tag}' of its type {type_name} is also used by another {family} type linked into this program, so neither could be loaded from a file; give one of them another #[typetag::serde(name = ...)]", kind = .0.kind, name = .0.name, tag = .0.tag, type_name = .0.type_name, family = .0.family)]
    TagShared(Box<TagProblem>),
    /// The declared tag is not the one the type is serialized under.
    #[error("{kind} '{name}': its type {type_name} declares the tag '{tag}' (Tagged::TAG), but no {family} implementation is saved under that name; write #[typetag::serde(name = \"{tag}\")] on its impl", kind = .0.kind, name = .0.name, tag = .0.tag, type_name = .0.type_name, family = .0.family)]
    TagMissing(Box<TagProblem>),
}

/// A part whose saved tag is a problem.
#[derive(Debug, Clone, PartialEq)]
pub struct TagProblem {
    /// Kind of part.
    pub kind: &'static str,
    /// The part.
    pub name: String,
    /// Its type.
    pub type_name: String,
    /// The trait the type is saved as.
    pub family: &'static str,
    /// The tag.
    pub tag: String,
}

/// Two registered parts of different types saved under one tag.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("{kind} '{name}': its type {type_name} is saved under the tag '{tag}', which {kind} '{other}' ({other_type}) already uses; give one of them another #[typetag::serde(name = ...)]")]
pub struct TagCollision {
    /// Kind of part.
    pub kind: &'static str,
    /// The part being registered.
    pub name: String,
    /// Its type.
    pub type_name: String,
    /// The shared tag.
    pub tag: String,
    /// The part registered before with that tag.
    pub other: String,
    /// Its type.
    pub other_type: String,
}

/// What a registry needs to know of a part beyond its name: the tag its saved form carries,
/// if it has one. Implemented by every registry's payload type.
///
/// ```
/// use drive_traits::{Registry, RegistryItem};
/// use std::sync::Arc;
/// /// A user's kind of part that is never saved: no tag.
/// struct Colour(&'static str);
/// impl RegistryItem for Colour {}
/// let mut colours: Registry<Colour> = Registry::new("colour");
/// colours.register("red", "for the plots", Arc::new(Colour("#d62728"))).unwrap();
/// assert!(colours.get("red").unwrap().tag().is_none());
/// ```
pub trait RegistryItem {
    /// The tag of the type this part saves into files (a fitted model, a vehicle), if any.
    fn part_tag(&self) -> Option<PartTag> {
        None
    }

    /// Checks what every part of this kind must satisfy (a vehicle's number of input axes);
    /// `Err` says what is wrong. Nothing by default.
    fn check_part(&self) -> Result<(), InvalidPart> {
        Ok(())
    }
}

/// One registered part.
pub struct Entry<T: ?Sized> {
    name: String,
    description: String,
    tag: Option<PartTag>,
    part: Arc<T>,
}

impl<T: ?Sized> std::fmt::Debug for Entry<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Entry")
            .field("name", &self.name)
            .field("tag", &self.tag)
            .finish_non_exhaustive()
    }
}

impl<T: ?Sized> Clone for Entry<T> {
    fn clone(&self) -> Self {
        Entry {
            name: self.name.clone(),
            description: self.description.clone(),
            tag: self.tag.clone(),
            part: Arc::clone(&self.part),
        }
    }
}

impl<T: ?Sized> Entry<T> {
    /// The registered name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// A one-line description.
    pub fn description(&self) -> &str {
        &self.description
    }
    /// The part.
    pub fn part(&self) -> &Arc<T> {
        &self.part
    }
    /// The tag its saved form carries, when it has one.
    pub fn tag(&self) -> Option<&PartTag> {
        self.tag.as_ref()
    }
}

/// Parts of one kind by name, in registration order.
///
/// ```
/// use drive_traits::{Registry, RegistryError, RegistryItem};
/// use std::sync::Arc;
///
/// /// A user's part: here, a named gain.
/// struct Gain(f64);
/// impl RegistryItem for Gain {}
///
/// let mut gains: Registry<Gain> = Registry::new("gain");
/// gains.register("half", "halves everything", Arc::new(Gain(0.5))).unwrap();
/// assert_eq!(gains.get("half").unwrap().part().0, 0.5);
/// assert!(matches!(gains.register("half", "again", Arc::new(Gain(1.0))),
///     Err(RegistryError::Duplicate { .. })));
/// assert!(gains.register("a+b", "", Arc::new(Gain(1.0))).is_err()); // '+' joins model parts
/// assert_eq!(gains.get("double").unwrap_err().to_string(),
///     "unknown gain 'double' (the gains are: half)");
/// ```
pub struct Registry<T: ?Sized> {
    kind: &'static str,
    entries: Vec<Entry<T>>,
}

impl<T: ?Sized> std::fmt::Debug for Registry<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Registry")
            .field("kind", &self.kind)
            .field("names", &self.names())
            .finish()
    }
}

impl<T: ?Sized> Clone for Registry<T> {
    fn clone(&self) -> Self {
        Registry {
            kind: self.kind,
            entries: self.entries.clone(),
        }
    }
}

/// Whether `name` can name a part: non-empty, ASCII letters, digits, `-` and `_`.
///
/// ```
/// assert!(drive_traits::is_part_name("slip-blr"));
/// assert!(!drive_traits::is_part_name("slip-blr+fopdt"));
/// ```
pub fn is_part_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
}

impl<T: ?Sized + RegistryItem> Registry<T> {
    /// An empty registry of parts of `kind` (the word used in messages: "powertrain",
    /// "slip learner", ...).
    pub fn new(kind: &'static str) -> Self {
        Registry {
            kind,
            entries: Vec::new(),
        }
    }

    /// The kind of part, as messages name it.
    pub fn kind(&self) -> &'static str {
        self.kind
    }

    /// Registers `part` under `name` with a one-line `description`. Refused, with the
    /// reason, when the name is malformed or taken, when the tag its saved form carries is
    /// not its serialized name, or when a registered part of another type has the same tag
    /// (the error names both). A tag shared with a type linked into the program but not
    /// registered is reported by [`Registry::check_tags`] (the command line runs it first).
    pub fn register(
        &mut self,
        name: &str,
        description: &str,
        part: Arc<T>,
    ) -> Result<&mut Self, RegistryError> {
        part.check_part().map_err(|reason| RegistryError::BadPart {
            kind: self.kind,
            name: name.to_string(),
            reason: reason.to_string(),
        })?;
        let tag = part.part_tag();
        if let Some(t) = &tag {
            if t.probe() == crate::TagProbe::Missing {
                return Err(RegistryError::TagMissing(Box::new(self.problem(name, t))));
            }
        }
        self.insert(name, description, tag, part)
    }

    /// Registers a part of this project without asking typetag about its tag (the checks
    /// between registered parts still apply).
    #[doc(hidden)]
    pub fn register_trusted(
        &mut self,
        name: &str,
        description: &str,
        part: Arc<T>,
    ) -> Result<&mut Self, RegistryError> {
        let tag = part.part_tag();
        self.insert(name, description, tag, part)
    }

    /// Asks typetag about the tag of every registered part: an error for the first tag
    /// that another linked type also uses, or that no type is serialized under.
    pub fn check_tags(&self) -> Result<(), RegistryError> {
        for e in &self.entries {
            if let Some(err) = e.tag.as_ref().and_then(|t| self.probe_error(&e.name, t)) {
                return Err(err);
            }
        }
        Ok(())
    }

    fn problem(&self, name: &str, t: &PartTag) -> TagProblem {
        TagProblem {
            kind: self.kind,
            name: name.to_string(),
            type_name: t.type_name.clone(),
            family: t.family,
            tag: t.tag.clone(),
        }
    }

    /// What typetag says of the tag of part `name`: `None` when exactly one type is saved
    /// under it.
    fn probe_error(&self, name: &str, t: &PartTag) -> Option<RegistryError> {
        match t.probe() {
            crate::TagProbe::Unique => None,
            crate::TagProbe::Missing => {
                Some(RegistryError::TagMissing(Box::new(self.problem(name, t))))
            }
            // Name the registered part of another type that holds the tag, when there is one.
            crate::TagProbe::Shared => Some(
                match self.entries.iter().find(|e| {
                    e.tag
                        .as_ref()
                        .is_some_and(|o| o.tag == t.tag && o.type_name != t.type_name)
                }) {
                    Some(e) => self.collision(name, t, e),
                    None => RegistryError::TagShared(Box::new(self.problem(name, t))),
                },
            ),
        }
    }

    fn collision(&self, name: &str, t: &PartTag, other: &Entry<T>) -> RegistryError {
        RegistryError::TagCollision(Box::new(TagCollision {
            kind: self.kind,
            name: name.to_string(),
            type_name: t.type_name.clone(),
            tag: t.tag.clone(),
            other: other.name.clone(),
            other_type: other
                .tag
                .as_ref()
                .map_or(String::new(), |o| o.type_name.clone()),
        }))
    }

    fn insert(
        &mut self,
        name: &str,
        description: &str,
        tag: Option<PartTag>,
        part: Arc<T>,
    ) -> Result<&mut Self, RegistryError> {
        if !is_part_name(name) {
            return Err(RegistryError::BadName {
                kind: self.kind,
                name: name.to_string(),
            });
        }
        if self.find(name).is_some() {
            return Err(RegistryError::Duplicate {
                kind: self.kind,
                name: name.to_string(),
            });
        }
        if let Some(t) = &tag {
            // The same type under two names (two configurations) is fine; two types under
            // one tag are not.
            if let Some(e) = self.entries.iter().find(|e| {
                e.tag
                    .as_ref()
                    .is_some_and(|o| o.tag == t.tag && o.type_name != t.type_name)
            }) {
                return Err(self.collision(name, t, e));
            }
        }
        self.entries.push(Entry {
            name: name.to_string(),
            description: description.to_string(),
            tag,
            part,
        });
        Ok(self)
    }
}

impl<T: ?Sized> Registry<T> {
    /// The entry registered under `name`, or an error listing the registered names.
    pub fn get(&self, name: &str) -> Result<&Entry<T>, RegistryError> {
        self.find(name).ok_or_else(|| RegistryError::Unknown {
            kind: self.kind,
            name: name.to_string(),
            known: self.names().join(", "),
        })
    }

    /// The entry registered under `name`, if any.
    pub fn find(&self, name: &str) -> Option<&Entry<T>> {
        self.entries.iter().find(|e| e.name == name)
    }

    /// Whether `name` is registered.
    pub fn contains(&self, name: &str) -> bool {
        self.find(name).is_some()
    }

    /// The registered names, in registration order.
    pub fn names(&self) -> Vec<&str> {
        self.entries.iter().map(|e| e.name.as_str()).collect()
    }

    /// Every entry, in registration order.
    pub fn entries(&self) -> &[Entry<T>] {
        &self.entries
    }

    /// Number of registered parts.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when nothing is registered.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}
