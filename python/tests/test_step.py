"""The step API from Python: `Model.initial_state`, `Model.step`, `drive.State` and the
pytorch_mppi adapter `drive.MppiDynamics`, against `Model.predict`; model files keep the
start a model was fitted for."""

import pickle

import numpy as np
import pytest

import drive


@pytest.fixture(scope="module")
def husky():
    return drive.load_dataset()


@pytest.fixture(scope="module")
def models(husky):
    return {name: drive.fit(husky, name, split=0.5, start="encoders+imu+localization") for name in ["slip-blr", "slip-ipem", "acc-blr", "powertrain"]}


def commands(n=41, seed=0):
    rng = np.random.default_rng(seed)
    held = rng.uniform(-6.0, 6.0, (4, 2))
    return np.repeat(held, (n + 3) // 4, axis=0)[:n]


def test_stepping_equals_predicting_with_and_without_covariance(models):
    start = dict(start=(1.0, -2.0, 0.4), start_wheels=(2.0, 3.5), start_yaw_rate=0.3, start_velocity=(0.2, 0.01))
    for name, model in models.items():
        cmds = commands()
        for covariance in (False, True):
            if covariance and name == "powertrain":
                with pytest.raises(drive.DriveError, match="uncertainty"):
                    model.initial_state(covariance=True)
                continue
            poses, cov = model.predict(cmds, return_cov=True, **start) if covariance else (model.predict(cmds, **start), None)
            state = model.initial_state(batch=3, covariance=covariance, **start)
            assert state.poses.shape == (3, 3) and state.body_velocities.shape == (3, 3)
            for k in range(len(cmds) - 1):
                np.testing.assert_allclose(state.poses, np.repeat(poses[k][None], 3, axis=0), rtol=0, atol=1e-12)
                if covariance:
                    np.testing.assert_allclose(state.covariances[1], cov[k], rtol=1e-12, atol=1e-15)
                state = model.step(state, np.repeat(cmds[k][None], 3, axis=0))
            assert list(state.steps) == [len(cmds) - 1] * 3


def test_a_dynamics_from_the_step_api_ends_where_the_rollout_ends(models):
    # The case: a dynamics(state, action) from predict_batch loses the powertrain's
    # dead time and lag at every call (0.57 m off after 2 s); the state keeps them.
    model = models["slip-blr"]
    cmds = commands()
    truth = model.predict(cmds, start_wheels=(1.0, 1.0))[-1]
    dyn = drive.MppiDynamics(model)
    x = dyn.initial_state(start_wheels=(1.0, 1.0))
    assert x.shape == (dyn.nx,) and dyn.nu == 2
    for u in cmds[:-1]:
        x = dyn(x, u)
    assert np.abs(dyn.poses(x) - truth).max() < 1e-12
    # Batched as pytorch_mppi calls it: K states, K actions.
    xs = np.repeat(dyn.initial_state(start_wheels=(1.0, 1.0))[None], 5, axis=0)
    for u in cmds[:-1]:
        xs = dyn(xs, np.repeat(u[None], 5, axis=0))
    assert np.abs(dyn.poses(xs) - truth).max() < 1e-12
    # Without the state: each step re-predicted from the last pose, the wheels taken to be
    # at the last command (the powertrain's dead time and lag forgotten), drifts.
    fwd = np.array([[5.0, 5.0]] * 20 + [[5.0, -1.0]] * 21)
    truth = model.predict(fwd)[-1]
    q, wheels = np.zeros(3), (0.0, 0.0)
    for u in fwd[:-1]:
        q = model.predict(np.array([u, u]), start=q, start_wheels=wheels)[1]
        wheels = tuple(u)
    assert np.linalg.norm(q[:2] - truth[:2]) > 0.1


def test_history_copy_inplace_and_errors(models):
    model = models["slip-blr"]
    cmds = commands()
    a = model.initial_state(start_wheels=(2.0, 2.0))
    b = model.initial_state(start_wheels=(2.0, 2.0), history=np.array([[6.0, -6.0]] * 20))
    c = a.copy()
    for u in cmds[:10]:
        a = model.step(a, u[None])
        b = model.step(b, u[None])
    # The commands already sent act inside the dead time.
    assert np.abs(a.poses - b.poses).max() > 1e-3
    # A copy is not stepped with the original; inplace steps the same object.
    assert np.all(c.poses == 0.0) and c.steps[0] == 0
    same = model.step(c, cmds[0][None], inplace=True)
    assert same is c and c.steps[0] == 1
    # The flat array is the state: pytorch_mppi's view of it.
    assert c.array.shape == (1, model.state_len())
    with pytest.raises(drive.DriveError, match=r"\(1, 2\)"):
        model.step(c, np.zeros((2, 2)))
    with pytest.raises(drive.DriveError, match="finite"):
        model.step(c, np.array([[np.nan, 0.0]]))
    with pytest.raises(drive.DriveError, match="another model"):
        models["slip-ipem"].step(c, cmds[0][None])
    with pytest.raises(drive.DriveError, match="history"):
        model.initial_state(history=np.zeros((3, 3)))
    with pytest.raises(drive.DriveError, match="covariance"):
        _ = c.covariances
    with pytest.raises(drive.DriveError, match="states hold"):
        model.step_array(np.zeros((2, 5)), np.zeros((2, 2)))
    # Issue 63 (a second sweep): actions and a start of 1e300 stepped without a word; they
    # are refused as Model.predict refuses them, and a yaw rate no data showed is warned of.
    with pytest.raises(drive.DriveError, match=r"row 0 is beyond 1e\+?0?9"):
        model.step(c, np.array([[1e300, 0.0]]))
    with pytest.raises(drive.DriveError, match="beyond"):
        drive.MppiDynamics(model)(c.array[0], np.array([0.0, 1e12]))
    with pytest.raises(drive.DriveError, match="start"):
        model.initial_state(start_velocity=(1e300, 0.0))
    with pytest.raises(drive.DriveError, match="history"):
        model.initial_state(history=np.array([[1e300, 0.0]]))
    with pytest.warns(UserWarning, match="start_yaw_rate.* over twice the fastest"):
        model.initial_state(start_yaw_rate=50.0)
    # A third sweep: a start velocity no data showed is warned of too, and a state edited
    # beyond 1e9 (or to NaN) is refused by step and step_array alike.
    with pytest.warns(UserWarning, match=r"start_velocity\[0\] is 50 m/s, over twice the fastest"):
        model.initial_state(start_velocity=(50.0, 0.0))
    edited = model.initial_state()
    edited.array[0, -1] = 1e12
    with pytest.raises(drive.DriveError, match="not a state the step API makes"):
        model.step(edited, np.zeros((1, 2)))
    with pytest.raises(drive.DriveError, match="not a state the step API makes"):
        drive.MppiDynamics(model)(edited.array[0], np.zeros(2))
    edited.array[0, -1] = np.nan
    with pytest.raises(drive.DriveError, match="not a state the step API makes"):
        model.step_array(edited.array, np.zeros((1, 2)))


def test_a_numpy_mppi_loop_drives_the_model_to_a_goal(models):
    # docs/python.md's loop: MPPI on the fitted model (256 sequences of 1.5 s) drives the
    # Husky to a goal 1 m ahead and 0.2 m to the left in 5 s of simulated driving. (Its
    # powertrain lags by about a second and it turns at a quarter of the commanded yaw
    # rate: a horizon of 1 s barely moves it.)
    model = models["slip-blr"]
    dyn = drive.MppiDynamics(model)
    rng = np.random.default_rng(1)
    K, T, lam = 256, 30, 1.0
    goal = np.array([1.0, 0.2])
    plan = np.zeros((T, 2))
    x = dyn.initial_state()
    for _ in range(100):
        actions = np.clip(plan[None] + rng.normal(0.0, 3.0, (K, T, 2)), -8.0, 8.0)
        xs = np.repeat(x[None], K, axis=0)
        cost = np.zeros(K)
        for t in range(T):
            xs = dyn(xs, actions[:, t])
            cost += np.sum((dyn.poses(xs)[:, :2] - goal) ** 2, axis=1)
        w = np.exp(-(cost - cost.min()) / lam)
        plan = np.einsum("k,ktu->tu", w / w.sum(), actions)
        x = dyn(x, plan[0])
        plan = np.roll(plan, -1, axis=0)
        plan[-1] = plan[-2]
    assert np.linalg.norm(dyn.poses(x)[:2] - goal) < 0.4


def test_model_files_and_pickles_keep_the_start_the_model_was_fitted_for(models, tmp_path, husky):
    model = models["slip-ipem"]
    assert model.start == "encoders+imu+localization"
    assert model.fitted_with["start"] == "encoders+imu+localization"
    path = tmp_path / "m.json"
    model.save(path)
    back = drive.load_model(path)
    assert back.start == "encoders+imu+localization"
    assert back.fitted_with == model.fitted_with
    # The same scores, from the same start (it changed silently before).
    ours, theirs = model.score(husky), back.score(husky)
    assert ours["translational_m"]["all"]["median"] == theirs["translational_m"]["all"]["median"]
    assert pickle.loads(pickle.dumps(model)).start == "encoders+imu+localization"
