//! Registering parts: a tag collision is an error at registration naming both parts, a
//! declared tag that is not the serialized one is refused, and a model name resolves to
//! the registered parts. (A test binary of its own: the colliding tags it registers would
//! make every model file's tag ambiguous in another test's binary.)

use drive_models::registry::builtin_slip_learners;
use drive_traits::{
    BodyVelocity, FitError, RegistryError, SlipData, SlipLearner, SlipModel, Tagged,
};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Two plug-ins' slip models that happen to use the same tag.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct FirstPlugin;
#[derive(Debug, Clone, Serialize, Deserialize)]
struct SecondPlugin;

#[typetag::serde(name = "shared-tag")]
impl SlipModel for FirstPlugin {
    fn slip(&self, _f: &BodyVelocity) -> BodyVelocity {
        BodyVelocity::zeros()
    }
    fn clone_box(&self) -> Box<dyn SlipModel> {
        Box::new(self.clone())
    }
}
impl Tagged for FirstPlugin {
    const TAG: &'static str = "shared-tag";
}

#[typetag::serde(name = "shared-tag")]
impl SlipModel for SecondPlugin {
    fn slip(&self, _f: &BodyVelocity) -> BodyVelocity {
        BodyVelocity::zeros()
    }
    fn clone_box(&self) -> Box<dyn SlipModel> {
        Box::new(self.clone())
    }
}
impl Tagged for SecondPlugin {
    const TAG: &'static str = "shared-tag";
}

/// A slip model whose declared tag is not its typetag name.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Mislabelled;
#[typetag::serde(name = "real-name")]
impl SlipModel for Mislabelled {
    fn slip(&self, _f: &BodyVelocity) -> BodyVelocity {
        BodyVelocity::zeros()
    }
    fn clone_box(&self) -> Box<dyn SlipModel> {
        Box::new(self.clone())
    }
}
impl Tagged for Mislabelled {
    const TAG: &'static str = "declared-name";
}

/// A slip model that took the built-in slip-BLR's tag.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Impostor;
#[typetag::serde(name = "slip-blr")]
impl SlipModel for Impostor {
    fn slip(&self, _f: &BodyVelocity) -> BodyVelocity {
        BodyVelocity::zeros()
    }
    fn clone_box(&self) -> Box<dyn SlipModel> {
        Box::new(self.clone())
    }
}
impl Tagged for Impostor {
    const TAG: &'static str = "slip-blr";
}

/// A learner of any of these.
struct Learn<M>(M);
impl<M: SlipModel + Tagged + Clone + 'static> SlipLearner for Learn<M> {
    type Fitted = M;
    fn fit(&self, _data: &SlipData<'_>) -> Result<M, FitError> {
        Ok(self.0.clone())
    }
}

#[test]
fn two_parts_with_one_tag_are_refused_at_registration_naming_both() {
    // An empty registry: the built-in slip-BLR shares its tag with `Impostor` in this test
    // program, which `check_tags` would report first.
    let mut r: drive_traits::Registry<dyn drive_traits::FitSlip> =
        drive_traits::Registry::new("slip learner");
    r.register("first", "", Arc::new(Learn(FirstPlugin)))
        .unwrap();
    let err = r
        .register("second", "", Arc::new(Learn(SecondPlugin)))
        .unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, RegistryError::TagCollision(_)), "{text}");
    for needle in [
        "'second'",
        "SecondPlugin",
        "'first'",
        "FirstPlugin",
        "'shared-tag'",
    ] {
        assert!(text.contains(needle), "{needle}: {text}");
    }
    // The first alone still shares its tag with a linked type: the check before a run says so.
    let shared = r.check_tags().unwrap_err();
    assert!(matches!(shared, RegistryError::TagShared(_)), "{shared}");
    assert!(shared.to_string().contains("'first'"), "{shared}");
}

#[test]
fn a_part_colliding_with_a_builtin_names_the_builtin() {
    let mut r = builtin_slip_learners();
    let err = r
        .register("mine", "", Arc::new(Learn(Impostor)))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("'mine'") && err.contains("'slip-blr'") && err.contains("SlipBlrModel"),
        "{err}"
    );
}

#[test]
fn a_declared_tag_that_is_not_the_serialized_one_is_refused() {
    let mut r = builtin_slip_learners();
    let err = r
        .register("mislabelled", "", Arc::new(Learn(Mislabelled)))
        .unwrap_err();
    assert!(matches!(err, RegistryError::TagMissing(_)), "{err}");
    assert!(err.to_string().contains("declared-name"), "{err}");
}

#[test]
fn the_same_type_under_two_names_is_not_a_collision() {
    let mut r = builtin_slip_learners();
    r.register(
        "slip-blr-phi1",
        "slip-BLR with phi = 1",
        Arc::new(drive_models::slip::SlipBlr::default().with_phi(1.0)),
    )
    .unwrap();
    assert_eq!(
        r.names(),
        ["no-slip", "slip-blr", "slip-ipem", "slip-blr-phi1"]
    );
}
