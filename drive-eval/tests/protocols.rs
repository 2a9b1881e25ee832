//! Table I on the simulator and on recorded data: the study's numbers are those of
//! training and testing each run directly, the improvements follow from them, and the
//! region split follows its definition.

use drive_eval::{
    compare_protocols, compare_regions, evaluate_model, improvement_percent, simulate_protocol,
    ExperimentError, ProtocolStudy, RegionStudy, Registries,
};
use drive_traits::{Input, RegistryError};

fn small_study() -> ProtocolStudy {
    let r = Registries::builtin();
    ProtocolStudy {
        robots: vec![r.robot("husky").unwrap()],
        terrains: vec![r.terrain("gravel").unwrap()],
        samplers: vec!["uniform".into(), "angular".into()],
        driving_s: vec![36.0],
        seeds: vec![4, 5],
        test_driving_s: 60.0,
        model: "slip-blr".into(),
    }
}

#[test]
fn study_cells_are_the_errors_of_training_and_testing_each_run() {
    let study = small_study();
    let r = Registries::builtin();
    let table = compare_protocols(&r, &study).unwrap();
    assert_eq!(table.cells.len(), 4);
    assert_eq!(table.rows.len(), 2);
    for cell in &table.cells {
        let train = simulate_protocol(&r, "husky", "gravel", &cell.sampler, 6, cell.seed)
            .unwrap()
            .dataset;
        let test = simulate_protocol(
            &r,
            "husky",
            "gravel",
            "uniform",
            10,
            ProtocolStudy::test_seed(cell.seed),
        )
        .unwrap()
        .dataset;
        assert_eq!((cell.train_windows, cell.test_windows), (18, 30));
        let model = r.model("slip-blr").unwrap().fit(&train.all()).unwrap();
        let report = evaluate_model(model.as_ref(), &test.all());
        assert_eq!(cell.translational, report.translational(None).unwrap());
        assert_eq!(cell.rotational, report.rotational(None).unwrap());
    }
    // Rows: medians over the two seeds (the mean of two values) and the improvement of
    // the reference from them.
    let mid = |sampler: &str, f: fn(&drive_eval::ProtocolCell) -> f64| {
        let v: Vec<f64> = table
            .cells
            .iter()
            .filter(|c| c.sampler == sampler)
            .map(f)
            .collect();
        (v[0] + v[1]) / 2.0
    };
    let angular = &table.rows[1];
    assert_eq!(angular.sampler, "angular");
    let (ta, tu) = (
        mid("angular", |c| c.translational.median),
        mid("uniform", |c| c.translational.median),
    );
    assert!((angular.translational_median_m - ta).abs() < 1e-15);
    assert!(
        (angular.reference_improvement_translational_percent - improvement_percent(tu, ta)).abs()
            < 1e-9
    );
    assert_eq!(table.rows[0].reference_improvement_rotational_percent, 0.0);
    assert!(angular.reference_wins_translational <= 2);
}

#[test]
fn a_study_is_deterministic() {
    let r = Registries::builtin();
    let a = compare_protocols(&r, &small_study()).unwrap();
    let b = compare_protocols(&r, &small_study()).unwrap();
    assert_eq!(a, b);
}

#[test]
fn a_study_refuses_what_cannot_run() {
    let r = Registries::builtin();
    let mut s = small_study();
    s.driving_s = vec![2.0];
    assert_eq!(
        compare_protocols(&r, &s),
        Err(ExperimentError::TooShort(2.0))
    );
    let mut s = small_study();
    s.model = "gp".into();
    assert!(matches!(
        compare_protocols(&r, &s),
        Err(ExperimentError::Registry(RegistryError::Unknown { name, .. })) if name == "gp"
    ));
    let mut s = small_study();
    s.seeds.clear();
    assert_eq!(
        compare_protocols(&r, &s),
        Err(ExperimentError::Empty("seeds"))
    );
    let mut s = small_study();
    s.samplers.push("zigzag".into());
    assert!(matches!(
        compare_protocols(&r, &s),
        Err(ExperimentError::Registry(RegistryError::Unknown { name, .. })) if name == "zigzag"
    ));
}

#[test]
fn regions_hold_the_intervals_their_definition_selects() {
    let r = Registries::builtin();
    let data = simulate_protocol(&r, "husky", "snow", "uniform", 60, 8)
        .unwrap()
        .dataset;
    let study = RegionStudy {
        draws: 4,
        ..RegionStudy::default()
    };
    let table = compare_regions(&r, &data, &study).unwrap();
    assert_eq!(table.train_intervals, 30);
    assert_eq!(table.eval_windows, 90);
    // Recount from the held commands (the last command of each training interval).
    let vehicle = data.robot.vehicle.as_ref();
    let held: Vec<Input> = data.windows[..90]
        .chunks(3)
        .map(|w| *w[2].command.last().unwrap())
        .collect();
    let [lx, hx] = table.input_space[0];
    let [ly, hy] = table.input_space[1];
    assert_eq!(lx, held.iter().map(|u| u.x).fold(f64::INFINITY, f64::min));
    assert_eq!(
        hy,
        held.iter().map(|u| u.y).fold(f64::NEG_INFINITY, f64::max)
    );
    assert_eq!(ly, held.iter().map(|u| u.y).fold(f64::INFINITY, f64::min));
    let turn = vehicle.body_velocity(&Input::new(lx, hy)).z.abs();
    let top = vehicle.body_velocity(&Input::new(hx, hy)).x;
    let linear = held
        .iter()
        .filter(|u| vehicle.body_velocity(u).z.abs() <= 0.15 * turn)
        .count();
    let angular = held
        .iter()
        .filter(|u| (0.25..=0.75).contains(&(vehicle.body_velocity(u).x / top)))
        .count();
    assert_eq!(table.regions[0].intervals, linear);
    assert_eq!(table.regions[1].intervals, angular);
    for r in &table.regions {
        let [lo, hi] = r.uniform_translational_range_m;
        assert!(lo <= r.uniform_translational_median_m && r.uniform_translational_median_m <= hi);
        let expected =
            improvement_percent(r.uniform_rotational_median_rad, r.region_rotational.median);
        assert_eq!(r.improvement_rotational_percent, expected);
    }
}

#[test]
fn regions_refuse_a_dataset_without_turns() {
    // Straight driving only: no turning-in-place rate to cut the regions with.
    let r = Registries::builtin();
    let mut data = simulate_protocol(&r, "husky", "tile", "uniform", 8, 1)
        .unwrap()
        .dataset;
    for w in &mut data.windows {
        for c in &mut w.command {
            *c = Input::new(2.0, 2.0);
        }
    }
    let err = compare_regions(&r, &data, &RegionStudy::default()).unwrap_err();
    assert!(
        matches!(err, ExperimentError::NotEnoughData(ref m) if m.contains("no turn")),
        "{err}"
    );
}
