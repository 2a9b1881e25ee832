//! Table I on the simulator and on recorded data: the cross-evaluation's numbers are those
//! of training and testing each run directly, the improvements follow from them, and the
//! region split follows its definition.

use drive_eval::{evaluate_model, improvement_percent, Summary};
use drive_studies::{
    compare_protocols, compare_regions, simulate_protocol, ExperimentError, ProtocolStudy,
    RegionStudy, Registries, MIXED,
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
        test_samplers: vec!["uniform".into(), "linear".into()],
        mixed_test: true,
        test_driving_s: 60.0,
        model: "slip-blr".into(),
    }
}

#[test]
fn study_cells_are_the_errors_of_training_and_testing_each_run() {
    let study = small_study();
    let r = Registries::builtin();
    let table = compare_protocols(&r, &study).unwrap();
    assert_eq!(table.test_sets, ["uniform", "linear", MIXED]);
    // 2 training samplers x 2 seeds x 3 test sets.
    assert_eq!(table.cells.len(), 12);
    assert_eq!(table.rows.len(), 6);
    let test_run = |sampler: &str, seed: u64| {
        simulate_protocol(
            &r,
            "husky",
            "gravel",
            sampler,
            10,
            ProtocolStudy::test_seed(seed),
        )
        .unwrap()
        .dataset
    };
    for cell in &table.cells {
        let train = simulate_protocol(&r, "husky", "gravel", &cell.train_sampler, 6, cell.seed)
            .unwrap()
            .dataset;
        let model = r.model("slip-blr").unwrap().fit(&train.all()).unwrap();
        let tests: Vec<&str> = if cell.test_sampler == MIXED {
            vec!["uniform", "linear"]
        } else {
            vec![cell.test_sampler.as_str()]
        };
        let (mut t, mut w) = (Vec::new(), Vec::new());
        for sampler in &tests {
            let report = evaluate_model(model.as_ref(), &test_run(sampler, cell.seed).all());
            t.extend(report.windows.iter().map(|w| w.error.translational));
            w.extend(report.windows.iter().map(|w| w.error.rotational));
        }
        assert_eq!(cell.train_windows, 18);
        assert_eq!(cell.test_windows, 30 * tests.len());
        assert_eq!(cell.translational, Summary::of(t).unwrap(), "{cell:?}");
        assert_eq!(cell.rotational, Summary::of(w).unwrap());
    }
    // Rows: medians of the errors of both seeds' test windows together, and the
    // improvement of the reference from them (its interval around it).
    let pooled = |train: &str, test: &str, pick: fn(&(usize, usize, f64, f64)) -> f64| {
        let v: Vec<f64> = table
            .cells
            .iter()
            .filter(|c| c.train_sampler == train && c.test_sampler == test)
            .flat_map(|c| c.errors.iter().map(pick))
            .collect();
        assert_eq!(v.len(), if test == MIXED { 120 } else { 60 });
        Summary::of(v).unwrap().median
    };
    for row in &table.rows {
        let (train, test) = (row.train_sampler.as_str(), row.test_sampler.as_str());
        let t = pooled(train, test, |e| e.2);
        assert!((row.translational_median_m - t).abs() < 1e-15);
        let imp = &row.reference_improvement_translational;
        let expected = improvement_percent(pooled("uniform", test, |e| e.2), t);
        assert!((imp.percent - expected).abs() < 1e-9, "{row:?}");
        if train == "uniform" {
            assert_eq!(imp.percent, 0.0);
            assert_eq!(imp.ci, [0.0, 0.0]);
        } else {
            assert!(
                imp.ci[0] <= imp.percent && imp.percent <= imp.ci[1],
                "{row:?}"
            );
        }
        assert!(row.reference_wins_translational <= 2 && row.seeds == 2);
    }
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
    s.test_samplers.clear();
    assert_eq!(
        compare_protocols(&r, &s),
        Err(ExperimentError::Empty("test samplers"))
    );
    let mut s = small_study();
    s.test_samplers.push("zigzag".into());
    assert!(matches!(
        compare_protocols(&r, &s),
        Err(ExperimentError::Registry(RegistryError::Unknown { name, .. })) if name == "zigzag"
    ));
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
    let turn = vehicle.body_velocity(&Input::new(lx, hy, 0.0)).z.abs();
    let top = vehicle.body_velocity(&Input::new(hx, hy, 0.0)).x;
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
            *c = Input::new(2.0, 2.0, 0.0);
        }
    }
    let err = compare_regions(&r, &data, &RegionStudy::default()).unwrap_err();
    assert!(
        matches!(err, ExperimentError::NotEnoughData(ref m) if m.contains("no turn")),
        "{err}"
    );
}
