"""A fitted model as the dynamics of a sampling-based controller: pytorch_mppi's
`dynamics(state, action) -> next_state` over the step API (`Model.step_array`)."""

import numpy as _np

from ._native import DriveError


def _is_torch(x):
    return type(x).__module__.split(".")[0] == "torch"


class MppiDynamics:
    """The dynamics of a fitted model with pytorch_mppi's signature:
    `dynamics(state, action) -> next_state`, `state` (K, nx) the model's stepped states
    flattened to floats (numbers 0-2 the pose x, y, yaw; see `drive.State.array`), `action`
    (K, nu) one command per state (the vehicle's inputs: left and right wheel velocities in
    rad/s for a differential drive). numpy arrays in, numpy arrays out; torch tensors in,
    torch tensors out (on the tensor's device and dtype; use `dtype=torch.double`: the
    states hold counters and indices that float32 rounds beyond 2^24). torch is never
    imported by this module.

        >>> dyn = drive.MppiDynamics(model)
        >>> x0 = dyn.initial_state(start=(0.0, 0.0, 0.0), start_wheels=(0.0, 0.0))
        >>> # pytorch_mppi.MPPI(dyn, running_cost, dyn.nx, noise_sigma, ...)
        >>> x1 = dyn(x0[None, :], np.array([[2.0, 3.0]]))      # (1, nx)
        >>> dyn.poses(x1)                                        # (1, 3)

    Stepping from `initial_state` k times gives row k of `model.predict` from the same
    start: the powertrain's dead time and the wheels' lag (and slip-ipem's lagging body
    velocity) live in the state, not in the controller.
    """

    def __init__(self, model, covariance=False, max_steps=None):
        self.model = model
        self.covariance = bool(covariance)
        self.max_steps = max_steps
        self.nx = model.state_len(covariance=self.covariance, max_steps=max_steps)
        self.nu = model.n_inputs

    def initial_state(self, **start):
        """One state (nx,) at a start, as `Model.initial_state` takes it (start,
        start_wheels, start_yaw_rate, start_velocity, history)."""
        if "batch" in start or "covariance" in start or "max_steps" in start:
            raise DriveError("initial_state takes the start only: batch, covariance and max_steps are the dynamics'")
        state = self.model.initial_state(covariance=self.covariance, max_steps=self.max_steps, **start)
        return state.array[0].copy()

    def __call__(self, state, action, t=None):
        if _is_torch(state):
            import torch

            s = state.detach().to("cpu", torch.float64).numpy()
            a = action.detach().to("cpu", torch.float64).numpy()
            out = self._step(s, a)
            return torch.as_tensor(out, dtype=state.dtype, device=state.device)
        return self._step(_np.asarray(state, dtype=_np.float64), _np.asarray(action, dtype=_np.float64))

    def _step(self, s, a):
        if s.ndim == 1:
            return self.model.step_array(s[None, :], _np.reshape(a, (1, -1)), self.covariance, self.max_steps)[0]
        return self.model.step_array(s, a, self.covariance, self.max_steps)

    @staticmethod
    def poses(states):
        """The poses (..., 3) of states (..., nx): x, y, yaw."""
        return states[..., 0:3]

    @staticmethod
    def body_velocities(states):
        """The body velocities over the last step (..., 3) of states (..., nx)."""
        return states[..., 3:6]

    def __repr__(self):
        return f"MppiDynamics({self.model.name!r}, nx={self.nx}, nu={self.nu}, covariance={self.covariance})"
