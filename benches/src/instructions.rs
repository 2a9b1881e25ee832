//! The workloads of the instruction-count guard (issue 35): each one runs once, on one thread,
//! deterministically, so that `valgrind --tool=cachegrind` counts the same instructions on
//! every run of the same code. `.ci/instructions` runs them and compares the counts with
//! the checked-in baseline `.ci/instructions-baseline.txt`.
//!
//! ```sh
//! cargo build --release -p drive-benches --features instructions --bin instructions
//! target/release/instructions train/slip-ipem   # one workload
//! target/release/instructions --list            # their names
//! ```
//!
//! Timings are criterion's job (`cargo bench`, see BENCHMARKS.md); these workloads are
//! smaller than criterion's so that the guard runs in seconds under valgrind.

use drive::eval::split_by_interval;
use drive::models::powertrain::Fopdt;
use drive::models::slip::{SlipBlr, SlipIpem};
use drive::models::Composed;
use drive::traits::{Dataset, Input, Learner, MotionModel, Pose, StartState, WindowSet};
use std::hint::black_box;
use std::process::ExitCode;

/// The workloads: name and what it runs.
const WORKLOADS: [(&str, &str); 11] = [
    (
        "train/slip-blr",
        "slip-BLR on the FOPDT fitted on the bundled Husky's training half",
    ),
    (
        "train/slip-ipem",
        "slip-ipem on the FOPDT fitted on the first 8 intervals of the bundled Husky's training half (the ridge path on 4 of them, then the final fit)",
    ),
    (
        "rollout/slip-blr",
        "2,000 40-step mean rollouts of slip-BLR",
    ),
    (
        "rollout/slip-ipem",
        "2,000 40-step mean rollouts of slip-ipem",
    ),
    (
        "covariance/slip-ipem",
        "20 40-step rollouts of slip-ipem with its pose covariance",
    ),
    (
        "batch/slip-blr",
        "predict_batch_into of 10,000 x 40 steps with slip-BLR, one thread",
    ),
    (
        "train-command/slip-blr",
        "drive train --model slip-blr --split 0.5 (the default, calibrated uncertainty: the fit, two fold refits and the calibration), the bundled data read included",
    ),
    (
        "train-command/slip-blr-paper",
        "drive train --model slip-blr --split 0.5 --uncertainty paper",
    ),
    (
        "step/slip-blr",
        "2,000 stepped states of slip-BLR rolled through 40 commands each (rollout_states: what Nav2's plug-in and the C library's drive_state_rollout run), one thread",
    ),
    (
        "step/slip-ipem",
        "2,000 stepped states of slip-ipem rolled through 40 commands each, one thread",
    ),
    (
        "step-batch/slip-blr",
        "2,000 stepped states of slip-BLR stepped 40 times one command at a time (step_batch: what Python's Model.step and pytorch_mppi's dynamics run)",
    ),
];

fn main() -> ExitCode {
    let name = std::env::args().nth(1).unwrap_or_default();
    if name == "--list" {
        for (n, what) in WORKLOADS {
            println!("{n}\t{what}");
        }
        return ExitCode::SUCCESS;
    }
    match run(&name) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The training half of the bundled Husky, its first `intervals` intervals (all when `None`).
fn training(data: &Dataset, intervals: Option<usize>) -> Result<WindowSet<'_>, String> {
    let (mut train, _) = split_by_interval(data, 0.5).map_err(|e| e.to_string())?;
    if let Some(n) = intervals {
        let first = train.windows.first().map_or(0, |w| w.interval);
        train.windows.retain(|w| w.interval < first + n);
    }
    Ok(train)
}

/// `n` command sequences of 40 steps from the evaluation windows, each perturbed.
fn sequences(data: &Dataset, n: usize) -> Result<(Vec<StartState>, Vec<Input>), String> {
    let (_, eval) = split_by_interval(data, 0.5).map_err(|e| e.to_string())?;
    let vehicle = data.robot.vehicle.as_ref();
    let mut starts = Vec::with_capacity(n);
    let mut commands = Vec::with_capacity(n * 40);
    for i in 0..n {
        let w = eval.windows[i % eval.len()];
        starts.push(w.start_state(vehicle));
        let e = (i as f64 * 0.618).fract() - 0.5;
        commands.extend(w.command.iter().map(|u| u + Input::new(e, -e, 0.0)));
    }
    Ok((starts, commands))
}

/// Callgrind's client requests (valgrind/callgrind.h): what `.ci/instructions` counts is
/// only what runs between [`measured`]'s start and stop (callgrind runs with
/// `--instr-atstart=no`), not loading the data or the fit a rollout workload needs first.
/// Outside valgrind the request is a no-op sequence (four rotations of a register by 128
/// bits in all, and an exchange of a register with itself).
#[cfg(target_arch = "x86_64")]
fn callgrind_request(request: u64) {
    let args: [u64; 6] = [request, 0, 0, 0, 0, 0];
    // SAFETY: valgrind's documented magic sequence; it reads `args` (six words, alive for
    // the whole statement) through rax, writes its result to rdx, and leaves rdi as it was.
    unsafe {
        std::arch::asm!(
            "rol rdi, 3",
            "rol rdi, 13",
            "rol rdi, 61",
            "rol rdi, 51",
            "xchg rbx, rbx",
            in("rax") args.as_ptr(),
            inout("rdx") 0u64 => _,
            inout("rdi") 0u64 => _,
        );
    }
}

#[cfg(not(target_arch = "x86_64"))]
fn callgrind_request(_request: u64) {}

/// `VG_USERREQ_TOOL_BASE('C', 'T')`: callgrind's first request.
const CALLGRIND_BASE: u64 = (b'C' as u64) << 24 | (b'T' as u64) << 16;

/// Runs `f` with callgrind's instrumentation on (requests START and STOP_INSTRUMENTATION).
fn measured<R>(f: impl FnOnce() -> R) -> R {
    callgrind_request(CALLGRIND_BASE + 4);
    let r = f();
    callgrind_request(CALLGRIND_BASE + 5);
    r
}

fn fit(learner: &Composed, train: &WindowSet<'_>) -> Result<Box<dyn MotionModel>, String> {
    let model = learner.fit(train).map_err(|e| e.to_string())?;
    Ok(Box::new(model))
}

fn rollouts(model: &dyn MotionModel, starts: &[StartState], commands: &[Input]) {
    let mut poses = Vec::with_capacity(40);
    for (start, c) in starts.iter().zip(commands.chunks(40)) {
        model.predict_into(black_box(start), black_box(c), &mut poses);
        black_box(&poses);
    }
}

fn covariances(
    model: &dyn MotionModel,
    starts: &[StartState],
    commands: &[Input],
) -> Result<(), String> {
    let (mut poses, mut covs) = (Vec::new(), Vec::new());
    for (start, c) in starts.iter().zip(commands.chunks(40)) {
        model
            .predict_with_covariance_into(start, c, &mut poses, &mut covs)
            .map_err(|e| e.to_string())?;
        black_box(&covs);
    }
    Ok(())
}

fn batch(
    model: &dyn MotionModel,
    starts: &[StartState],
    commands: &[Input],
    poses: &mut [Pose],
) -> Result<(), String> {
    model
        .predict_batch_into(starts, commands, 40, poses)
        .map_err(|e| e.to_string())
}

fn run(name: &str) -> Result<(), String> {
    let data = drive::bundled::husky().map_err(|e| e.to_string())?;
    let blr = Composed::new(Fopdt::default(), SlipBlr::default());
    let full = training(&data, None)?;
    // slip-ipem's fit is about 10^9 instructions per 16 training intervals: the guard's
    // fit has 8, half of them held out for the ridge path (at least 3 are needed); the
    // rollout workloads' model is fitted on 4 with one ridge strength (its quality does not
    // change what a rollout costs).
    let short = training(&data, Some(8))?;
    let tiny = training(&data, Some(4))?;
    let ipem_guard = Composed::new(
        Fopdt::default(),
        SlipIpem {
            validation: 0.5,
            ..SlipIpem::default()
        },
    );
    let ipem_setup = Composed::new(
        Fopdt::default(),
        SlipIpem {
            ridge: vec![1e-2],
            ..SlipIpem::default()
        },
    );
    match name {
        "train/slip-blr" => {
            black_box(measured(|| fit(&blr, &full))?);
        }
        "train/slip-ipem" => {
            black_box(measured(|| fit(&ipem_guard, &short))?);
        }
        "rollout/slip-blr" | "rollout/slip-ipem" => {
            let model = if name == "rollout/slip-blr" {
                fit(&blr, &full)?
            } else {
                fit(&ipem_setup, &tiny)?
            };
            let (starts, commands) = sequences(&data, 2_000)?;
            measured(|| rollouts(model.as_ref(), &starts, &commands));
        }
        "covariance/slip-ipem" => {
            let model = fit(&ipem_setup, &tiny)?;
            let (starts, commands) = sequences(&data, 20)?;
            measured(|| covariances(model.as_ref(), &starts, &commands))?;
        }
        "batch/slip-blr" => {
            let model = fit(&blr, &full)?;
            let (starts, commands) = sequences(&data, 10_000)?;
            let mut poses = vec![Pose::zeros(); commands.len()];
            measured(|| batch(model.as_ref(), &starts, &commands, black_box(&mut poses)))?;
            black_box(&poses);
        }
        "step/slip-blr" | "step/slip-ipem" | "step-batch/slip-blr" => {
            use drive::models::batch::rollout_states;
            use drive::traits::step::{StepOptions, StepOutputs};
            let model = if name.ends_with("slip-blr") {
                fit(&blr, &full)?
            } else {
                fit(&ipem_setup, &tiny)?
            };
            let (starts, commands) = sequences(&data, 2_000)?;
            let stepper = model
                .stepper(StepOptions::default())
                .map_err(|e| e.to_string())?;
            let len = stepper.state_len();
            let mut states = vec![0.0; starts.len() * len];
            for (s, start) in states.chunks_exact_mut(len).zip(&starts) {
                stepper.init(start, &[], s).map_err(|e| e.to_string())?;
            }
            if name.starts_with("step-batch") {
                let by_step: Vec<Vec<Input>> = (0..40)
                    .map(|t| commands.iter().skip(t).step_by(40).copied().collect())
                    .collect();
                measured(|| -> Result<(), String> {
                    for now in &by_step {
                        stepper
                            .step_batch(black_box(&mut states), now)
                            .map_err(|e| e.to_string())?;
                    }
                    Ok(())
                })?;
            } else {
                let mut velocities = vec![drive::traits::BodyVelocity::zeros(); commands.len()];
                measured(|| {
                    let outputs = StepOutputs {
                        velocities: Some(&mut velocities),
                        ..Default::default()
                    };
                    rollout_states(
                        stepper.as_ref(),
                        &mut states,
                        &commands,
                        40,
                        outputs,
                        starts.len(),
                    )
                    .map_err(|e| e.to_string())
                })?;
                black_box(&velocities);
            }
            black_box(&states);
        }
        "train-command/slip-blr" | "train-command/slip-blr-paper" => {
            let out =
                std::env::temp_dir().join(format!("instructions-{}.json", std::process::id()));
            let mut args = vec!["drive", "train", "--model", "slip-blr", "--split", "0.5"];
            if name.ends_with("paper") {
                args.extend(["--uncertainty", "paper"]);
            }
            let out_arg = out.display().to_string();
            args.extend(["--out", out_arg.as_str()]);
            let registries = drive::Registries::builtin();
            let status = measured(|| drive::cli::run_status(args, &registries));
            let _ = std::fs::remove_file(&out);
            if status != 0 {
                return Err(format!("drive train exited with {status}"));
            }
        }
        other => {
            let names: Vec<&str> = WORKLOADS.iter().map(|(n, _)| *n).collect();
            return Err(format!(
                "unknown workload '{other}'; one of {}",
                names.join(", ")
            ));
        }
    }
    Ok(())
}
