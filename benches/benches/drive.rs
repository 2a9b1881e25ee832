//! Criterion benchmarks of the issue-5 targets (load, train, eval, predict, batch) and of
//! slip-ipem (issue 13) and of `drive converge`'s scaling (issue 14).
//!
//! `cargo bench --bench drive`; one core: `RAYON_NUM_THREADS=1` is not needed, the
//! single-core cases run on the calling thread. See BENCHMARKS.md.

use criterion::{criterion_group, criterion_main, Criterion};
use drive::eval::{evaluate_model, split_by_interval};
use drive::models::batch::predict_batch_parallel;
use drive::models::powertrain::Fopdt;
use drive::models::slip::{SlipBlr, SlipIpem};
use drive::models::Composed;
use drive::studies::{compare, convergence_with, ConvergenceConfig};
use drive::traits::{Input, Learner, MotionModel, Pose, StartState};
use drive::Registries;

/// The paper's slip-BLR: slip-BLR on the FOPDT, composed with the data's vehicle.
fn slip_blr() -> Composed {
    Composed::new(Fopdt::default(), SlipBlr::default())
}
use std::hint::black_box;

fn load(c: &mut Criterion) {
    c.bench_function("load/bundled husky (gunzip + parse)", |b| {
        b.iter(|| drive::bundled::husky().unwrap())
    });
}

fn train(c: &mut Criterion) {
    let data = drive::bundled::husky().unwrap();
    let (train, _) = split_by_interval(&data, 0.5).unwrap();
    c.bench_function(
        "train/slip-blr (powertrain both sides + BLR), husky training half",
        |b| b.iter(|| slip_blr().fit(black_box(&train)).unwrap()),
    );
    c.bench_function("train/powertrain only", |b| {
        b.iter(|| {
            drive::traits::PowertrainLearner::fit(&Fopdt::default(), black_box(&train)).unwrap()
        })
    });
}

fn eval(c: &mut Criterion) {
    let data = drive::bundled::husky().unwrap();
    let names = ["naive", "powertrain", "slip-blr", "acc-blr"];
    let registries = Registries::builtin();
    c.bench_function("eval/4 models, fit + score, husky (excluding load)", |b| {
        b.iter(|| compare(&registries, black_box(&data), 0.5, &names).unwrap())
    });
    let (train, eval) = split_by_interval(&data, 0.5).unwrap();
    let model = slip_blr().fit(&train).unwrap();
    c.bench_function("eval/score slip-blr on 303 windows", |b| {
        b.iter(|| evaluate_model(black_box(&model), &eval))
    });
}

/// A fitted slip-BLR model and n command sequences of 40 steps from the evaluation windows.
fn fixture(n: usize) -> (Box<dyn MotionModel>, Vec<StartState>, Vec<Input>) {
    let data = drive::bundled::husky().unwrap();
    let (train, eval) = split_by_interval(&data, 0.5).unwrap();
    let model = slip_blr().fit(&train).unwrap();
    let vehicle = data.robot.vehicle.as_ref();
    let mut starts = Vec::with_capacity(n);
    let mut commands = Vec::with_capacity(n * 40);
    for i in 0..n {
        let w = eval.windows[i % eval.len()];
        starts.push(w.start_state(vehicle));
        // Perturb so that no two sequences are the same.
        let e = (i as f64 * 0.618).fract() - 0.5;
        commands.extend(w.command.iter().map(|u| u + Input::new(e, -e, 0.0)));
    }
    (Box::new(model), starts, commands)
}

fn predict(c: &mut Criterion) {
    let (model, starts, commands) = fixture(1);
    let mut poses = Vec::with_capacity(40);
    c.bench_function("predict/slip-blr 40-step mean rollout", |b| {
        b.iter(|| model.predict_into(black_box(&starts[0]), black_box(&commands), &mut poses))
    });
    let mut covs = Vec::with_capacity(40);
    c.bench_function("predict/slip-blr 40-step rollout with covariance", |b| {
        b.iter(|| {
            model
                .predict_with_covariance_into(
                    black_box(&starts[0]),
                    black_box(&commands),
                    &mut poses,
                    &mut covs,
                )
                .unwrap()
        })
    });
}

fn batch(c: &mut Criterion) {
    let (model, starts, commands) = fixture(10_000);
    let mut group = c.benchmark_group("batch");
    group.sample_size(30);
    // One caller-provided buffer, reused (as a controller would), so page faults of a fresh
    // 9.6 MB allocation are not timed.
    let mut poses = vec![Pose::zeros(); commands.len()];
    group.bench_function("slip-blr 10000 x 40 steps, one core", |b| {
        b.iter(|| {
            model
                .predict_batch_into(&starts, &commands, 40, black_box(&mut poses))
                .unwrap()
        })
    });
    group.bench_function(
        format!(
            "slip-blr 10000 x 40 steps, all cores ({})",
            rayon::current_num_threads()
        ),
        |b| {
            b.iter(|| {
                predict_batch_parallel(
                    model.as_ref(),
                    &starts,
                    &commands,
                    40,
                    black_box(&mut poses),
                    256,
                )
                .unwrap()
            })
        },
    );
    group.finish();
}

/// slip-ipem (issue 13): training on the husky training half (the ridge path on the inner
/// split and the final fit; one thread) and one 40-step rollout.
fn ipem(c: &mut Criterion) {
    let data = drive::bundled::husky().unwrap();
    let (train, eval) = split_by_interval(&data, 0.5).unwrap();
    let learner = Composed::new(Fopdt::default(), SlipIpem::default());
    let mut group = c.benchmark_group("slip-ipem");
    group.sample_size(10);
    group.bench_function("train, husky training half", |b| {
        b.iter(|| learner.fit(black_box(&train)).unwrap())
    });
    // What `drive train --model slip-ipem` fits by default (--start encoders+imu): the
    // windows without their start velocity (ModelSpec::fit drops it), so no start-velocity
    // trust is fitted; the figure BENCHMARKS.md compared before the start velocity existed.
    let mut without = data.clone();
    for w in &mut without.windows {
        w.start_velocity = None;
    }
    let (train_default, _) = split_by_interval(&without, 0.5).unwrap();
    group.bench_function(
        "train, husky training half, default start (no start velocity)",
        |b| b.iter(|| learner.fit(black_box(&train_default)).unwrap()),
    );
    group.finish();
    let model = learner.fit(&train).unwrap();
    let w = eval.windows[0];
    let start = w.start_state(data.robot.vehicle.as_ref());
    let mut poses = Vec::with_capacity(40);
    c.bench_function("predict/slip-ipem 40-step mean rollout", |b| {
        b.iter(|| model.predict_into(black_box(&start), black_box(&w.command), &mut poses))
    });
    let mut covs = Vec::with_capacity(40);
    c.bench_function("predict/slip-ipem 40-step rollout with covariance", |b| {
        b.iter(|| {
            model
                .predict_with_covariance_into(
                    black_box(&start),
                    black_box(&w.command),
                    &mut poses,
                    &mut covs,
                )
                .unwrap()
        })
    });
}

/// One tick of the MPPI controller (issue 30): 1024 candidates of 40 steps after half a
/// second of history (the `drive track` default), rolled out with slip-BLR and with
/// slip-ipem fitted on the husky training half, scored against a figure-eight; one core.
fn control(c: &mut Criterion) {
    use drive::control::{ControlSetup, ControlState, InputMap, MakeController, Mppi, PathShape};
    use std::sync::Arc;
    let data = drive::bundled::husky().unwrap();
    let (train, eval) = split_by_interval(&data, 0.5).unwrap();
    let husky = Registries::builtin().robot("husky").unwrap();
    let path = PathShape::FigureEight.at_scale(4.0).unwrap();
    let reference: Vec<Pose> = (1..=40)
        .map(|k| path.point_at(0.025 * k as f64).pose())
        .collect();
    let w = eval.windows[5];
    let start = w.start_state_with(
        data.robot.vehicle.as_ref(),
        drive::traits::StartInfo::EncodersImu,
    );
    let past: Vec<Input> = w.command[..10].to_vec();
    let mut group = c.benchmark_group("control");
    let models: [(&str, Box<dyn MotionModel>); 2] = [
        ("slip-blr", Box::new(slip_blr().fit(&train).unwrap())),
        (
            "slip-ipem",
            Box::new(
                Composed::new(Fopdt::default(), SlipIpem::default())
                    .fit(&train)
                    .unwrap(),
            ),
        ),
    ];
    for (name, model) in models {
        let setup = ControlSetup {
            model: Arc::from(model),
            robot: husky.clone(),
            to_vehicle: InputMap::identity(),
            speed: 0.5,
            seed: 0,
        };
        let state = ControlState {
            now: start,
            sent: Default::default(),
            past: Some((start, &past)),
        };
        // The candidates scored on their mean poses, then with their predicted variance
        // (`uncertainty_weight`: every candidate also rolled out with its covariance).
        let threads = format!(
            ", the variance rollouts on {} threads",
            rayon::current_num_threads()
        );
        for (what, weight, cores) in [
            ("", 0.0, ", one core"),
            (" with its variance", 1.0, threads.as_str()),
        ] {
            let mppi = Mppi {
                uncertainty_weight: weight,
                ..Mppi::default()
            };
            let mut controller = mppi.make(&setup).unwrap();
            group.bench_function(
                format!("mppi tick{what}, {name}, 1024 x 40 steps (+10 of history){cores}"),
                |b| {
                    b.iter(|| {
                        controller
                            .command(black_box(&state), black_box(&reference))
                            .unwrap()
                    })
                },
            );
        }
    }
    group.finish();
}

/// The bundled data repeated `times` times, each copy's intervals and windows renumbered
/// after the previous copy's (the issue-14 scaling case of `drive converge`).
fn repeated(times: usize) -> drive::traits::Dataset {
    let data = drive::bundled::husky().unwrap();
    let intervals = data.interval_count();
    let n = data.windows.len();
    let mut windows = Vec::with_capacity(n * times);
    for copy in 0..times {
        windows.extend(data.windows.iter().map(|w| {
            let mut w = w.clone();
            w.index += copy * n;
            w.interval += copy * intervals;
            w
        }));
    }
    drive::traits::Dataset {
        robot: data.robot.clone(),
        windows,
    }
}

/// `drive converge`'s analysis (issue 14) on the bundled data and on ten times it: online
/// slip-BLR, at most 100 points, the recording order and 30 random orders.
fn converge(c: &mut Criterion) {
    let registries = Registries::builtin();
    let spec = registries.model("slip-blr").unwrap().clone();
    let config = ConvergenceConfig::default();
    let mut group = c.benchmark_group("converge");
    group.sample_size(10);
    for times in [1, 10] {
        let data = repeated(times);
        group.bench_function(format!("slip-blr, bundled data x{times}"), |b| {
            b.iter(|| convergence_with(black_box(&data), &config, &spec).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, load, train, eval, predict, batch, ipem, converge, control, step, adapt);
criterion_main!(benches);

/// The step API (issue 59): a batch of states stepped one command at a time, at Nav2 MPPI's
/// default shape (2000 sequences of 56 steps), on all cores and on one; and one step of
/// 1024 states (the Python case's Rust side).
fn step(c: &mut Criterion) {
    use drive::models::batch::{rollout_states, step_batch_parallel};
    use drive::traits::step::StepOptions;
    use drive::traits::step::StepOutputs;
    let data = drive::bundled::husky().unwrap();
    let (train, eval) = split_by_interval(&data, 0.5).unwrap();
    let vehicle = data.robot.vehicle.as_ref();
    let registries = Registries::builtin();
    for name in ["slip-blr", "slip-ipem"] {
        let model = registries.model(name).unwrap().fit(&train).unwrap();
        let stepper = model.stepper(StepOptions::default()).unwrap();
        let len = stepper.state_len();
        let (n, horizon) = (2000, 56);
        let mut initial = vec![0.0; n * len];
        for (i, s) in initial.chunks_exact_mut(len).enumerate() {
            let w = eval.windows[i % eval.len()];
            stepper.init(&w.start_state(vehicle), &[], s).unwrap();
        }
        let commands: Vec<Input> = (0..n * horizon)
            .map(|i| {
                let w = eval.windows[(i / horizon) % eval.len()];
                let e = ((i / horizon) as f64 * 0.618).fract() - 0.5;
                w.command[(i % horizon) % 40] + Input::new(e, -e, 0.0)
            })
            .collect();
        let mut velocities = vec![drive::traits::BodyVelocity::zeros(); n * horizon];
        let mut states = initial.clone();
        c.bench_function(&format!("step/{name} 2000 x 56 steps, all cores"), |b| {
            b.iter(|| {
                states.copy_from_slice(&initial);
                let outputs = StepOutputs {
                    velocities: Some(&mut velocities),
                    ..Default::default()
                };
                rollout_states(
                    stepper.as_ref(),
                    &mut states,
                    &commands,
                    horizon,
                    outputs,
                    250,
                )
                .unwrap()
            })
        });
        c.bench_function(&format!("step/{name} 2000 x 56 steps, one core"), |b| {
            b.iter(|| {
                states.copy_from_slice(&initial);
                let outputs = StepOutputs {
                    velocities: Some(&mut velocities),
                    ..Default::default()
                };
                rollout_states(
                    stepper.as_ref(),
                    &mut states,
                    &commands,
                    horizon,
                    outputs,
                    n,
                )
                .unwrap()
            })
        });
        // The same through the C library (model file, drive_state_init, drive_state_rollout
        // with the commands as doubles): what a C or C++ controller calls.
        let text = drive::models::model_file::model_to_json(model.as_ref(), &data.robot).unwrap();
        let mut handle = std::ptr::null_mut();
        // SAFETY: the text's bytes and a valid out pointer.
        let status = unsafe {
            drive_capi::drive_model_from_json(text.as_ptr().cast(), text.len(), &mut handle)
        };
        assert_eq!(status, drive_capi::DRIVE_OK);
        let flat: Vec<f64> = commands.iter().flat_map(|u| [u.x, u.y]).collect();
        let mut c_states = vec![0.0; n * len];
        let mut c_velocities = vec![0.0; n * horizon * 3];
        let mut start = drive_capi::drive_start::default();
        // SAFETY: a valid start.
        unsafe { drive_capi::drive_start_rest(&mut start) };
        c.bench_function(
            &format!("step/{name} 2000 x 56 steps through the C library"),
            |b| {
                b.iter(|| {
                    // SAFETY: buffers of the sizes the calls read and write.
                    unsafe {
                        let s = drive_capi::drive_state_init(
                            handle,
                            0,
                            &start,
                            1,
                            std::ptr::null(),
                            0,
                            c_states.as_mut_ptr(),
                            n,
                        );
                        assert_eq!(s, drive_capi::DRIVE_OK);
                        let s = drive_capi::drive_state_rollout(
                            handle,
                            0,
                            c_states.as_mut_ptr(),
                            n,
                            flat.as_ptr(),
                            horizon,
                            std::ptr::null_mut(),
                            c_velocities.as_mut_ptr(),
                            std::ptr::null_mut(),
                        );
                        assert_eq!(s, drive_capi::DRIVE_OK);
                    }
                })
            },
        );
        // SAFETY: the model loaded above, freed once.
        unsafe { drive_capi::drive_model_free(handle) };
        let one: Vec<Input> = commands
            .iter()
            .step_by(horizon)
            .take(1024)
            .copied()
            .collect();
        let mut batch = initial[..1024 * len].to_vec();
        c.bench_function(
            &format!("step/{name} one step of 1024 states, one core"),
            |b| b.iter(|| stepper.step_batch(black_box(&mut batch), &one).unwrap()),
        );
        c.bench_function(
            &format!("step/{name} one step of 1024 states, all cores"),
            |b| {
                b.iter(|| {
                    step_batch_parallel(stepper.as_ref(), black_box(&mut batch), &one, 512).unwrap()
                })
            },
        );
    }
}

/// Adaptation (issue 61): a prior fitted on the bundled Husky's training half, the 60 first
/// windows of its evaluation half added one at a time to its slip correction (one core;
/// per window: the time / 60).
fn adapt(c: &mut Criterion) {
    use drive::models::adapt::{AdapterConfig, SlipAdapter};
    use drive::traits::WindowSet;
    let data = drive::bundled::husky().unwrap();
    let (train, eval) = split_by_interval(&data, 0.5).unwrap();
    for (name, learner) in [
        ("slip-blr", slip_blr()),
        (
            "slip-ipem",
            Composed::new(Fopdt::default(), SlipIpem::default()),
        ),
    ] {
        let prior = learner.fit(&train).unwrap();
        let windows: Vec<WindowSet<'_>> = eval.windows[..60]
            .iter()
            .map(|w| WindowSet {
                robot: &data.robot,
                windows: vec![*w],
            })
            .collect();
        c.bench_function(
            &format!("adapt/{name} slip correction, 60 windows added one at a time"),
            |b| {
                b.iter(|| {
                    let mut a =
                        SlipAdapter::new(prior.clone(), &data.robot, AdapterConfig::default());
                    for w in &windows {
                        a.add(black_box(w));
                    }
                    a.model()
                })
            },
        );
    }
}
