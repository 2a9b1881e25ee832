# Type hints of the drive package (the extension module `drive._native` and its Python layer).
import os
from collections.abc import Mapping, Sequence
from typing import Any, Literal, Optional, Union, overload

import numpy as np
import numpy.typing as npt

_Path = Union[str, os.PathLike[str]]
_Start = Literal["encoders", "encoders+imu", "encoders+imu+localization"]
_Models = Union[None, str, Sequence[str]]
_Array = npt.ArrayLike

class DriveError(ValueError): ...

class DriveFileNotFoundError(DriveError, FileNotFoundError):
    def __init__(self, message: str, filename: Optional[str] = ...) -> None: ...

class Dataset:
    @staticmethod
    def from_text(csv: str, sidecar: str) -> Dataset: ...
    @staticmethod
    def from_pandas(df: Any, meta: Mapping[str, Any]) -> Dataset: ...
    def to_pandas(self) -> Any: ...
    @property
    def meta(self) -> dict[str, Any]: ...
    @property
    def import_report(self) -> Optional[dict[str, Any]]: ...
    def sidecar_json(self) -> str: ...
    def save(self, path: _Path) -> None: ...
    def __len__(self) -> int: ...
    @property
    def intervals(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def rate_hz(self) -> float: ...

class AdaptiveModel:
    def __init__(self, prior: Model) -> None: ...
    def add(self, data: Dataset) -> None: ...
    def model(self) -> Model: ...
    @property
    def changed(self) -> bool: ...
    @property
    def windows(self) -> int: ...
    @property
    def prior(self) -> Model: ...
    def save(self, path: _Path) -> None: ...
    @staticmethod
    def load(path: _Path) -> AdaptiveModel: ...

class Model:
    @property
    def name(self) -> str: ...
    @property
    def dt(self) -> float: ...
    @property
    def start(self) -> _Start: ...
    @overload
    def predict(
        self,
        commands: _Array,
        start: Optional[_Array] = ...,
        start_wheels: Optional[_Array] = ...,
        start_yaw_rate: Optional[float] = ...,
        start_velocity: Optional[_Array] = ...,
        return_cov: Literal[False] = ...,
    ) -> npt.NDArray[np.float64]: ...
    @overload
    def predict(
        self,
        commands: _Array,
        start: Optional[_Array] = ...,
        start_wheels: Optional[_Array] = ...,
        start_yaw_rate: Optional[float] = ...,
        start_velocity: Optional[_Array] = ...,
        *,
        return_cov: Literal[True],
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def predict_batch(
        self,
        commands: _Array,
        starts: Optional[_Array] = ...,
        start_wheels: Optional[_Array] = ...,
        start_yaw_rates: Optional[_Array] = ...,
        start_velocities: Optional[_Array] = ...,
    ) -> npt.NDArray[np.float64]: ...
    def score(
        self,
        dataset: Dataset,
        start: Optional[_Start] = ...,
        allow_other_geometry: bool = ...,
        allow_useless: bool = ...,
    ) -> dict[str, Any]: ...
    def parameters(self) -> dict[str, Any]: ...
    def to_json(self) -> str: ...
    def save(self, path: _Path) -> None: ...
    @property
    def inputs(self) -> list[str]: ...
    @property
    def n_inputs(self) -> int: ...
    @property
    def fitted_with(self) -> Optional[dict[str, Any]]: ...
    def state_len(self, covariance: Optional[bool] = ..., max_steps: Optional[int] = ...) -> int: ...
    def initial_state(
        self,
        start: Optional[_Array] = ...,
        start_wheels: Optional[_Array] = ...,
        start_yaw_rate: Optional[Union[float, _Array]] = ...,
        start_velocity: Optional[_Array] = ...,
        history: Optional[_Array] = ...,
        batch: Optional[int] = ...,
        covariance: Optional[bool] = ...,
        max_steps: Optional[int] = ...,
    ) -> State: ...
    def step(self, state: State, actions: _Array, inplace: Optional[bool] = ...) -> State: ...
    def step_array(
        self,
        states: _Array,
        actions: _Array,
        covariance: Optional[bool] = ...,
        max_steps: Optional[int] = ...,
    ) -> npt.NDArray[np.float64]: ...

class State:
    @property
    def array(self) -> npt.NDArray[np.float64]: ...
    @property
    def poses(self) -> npt.NDArray[np.float64]: ...
    @property
    def body_velocities(self) -> npt.NDArray[np.float64]: ...
    @property
    def covariances(self) -> npt.NDArray[np.float64]: ...
    @property
    def steps(self) -> npt.NDArray[np.int64]: ...
    @property
    def batch(self) -> int: ...
    @property
    def with_covariance(self) -> bool: ...
    def copy(self) -> State: ...
    def __len__(self) -> int: ...

class MppiDynamics:
    model: Model
    covariance: bool
    nx: int
    nu: int
    def __init__(self, model: Model, covariance: bool = ..., max_steps: Optional[int] = ...) -> None: ...
    def initial_state(self, **start: Any) -> npt.NDArray[np.float64]: ...
    def __call__(self, state: Any, action: Any, t: Any = ...) -> Any: ...
    @staticmethod
    def poses(states: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
    @staticmethod
    def body_velocities(states: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...

class Command:
    @property
    def inputs(self) -> tuple[float, float]: ...
    @property
    def linear(self) -> float: ...
    @property
    def angular(self) -> float: ...
    @property
    def recording(self) -> bool: ...
    @property
    def interval(self) -> Optional[int]: ...
    @property
    def window(self) -> Optional[int]: ...
    @property
    def phase(self) -> Optional[Literal["transient", "steady"]]: ...

class Measurements:
    t: float
    encoder: Optional[tuple[float, float]]
    pose: Optional[tuple[float, float, float]]
    deadman: bool
    def __init__(
        self,
        t: float,
        encoder: Optional[Sequence[float]] = ...,
        pose: Optional[Sequence[float]] = ...,
        *,
        deadman: bool,
    ) -> None: ...

class ProtocolRunner:
    def __init__(self, robot: _Path, sampler: str = ..., seed: int = ..., **options: Any) -> None: ...
    def tick(self, measurements: Any = ..., **fields: Any) -> Command: ...
    def observe(self, interval: Dataset) -> None: ...
    state: str
    done: bool
    pause_reason: Optional[str]
    stop_reason: Optional[str]
    completed_intervals: int
    input_space: Optional[tuple[tuple[float, float], tuple[float, float]]]
    geometry: dict[str, float]
    robot: str
    rate_hz: float
    inputs: tuple[str, str]

class Tracker:
    def __init__(
        self,
        model: Model,
        robot: _Path,
        path: Union[str, _Array],
        speed: float,
        *,
        scale: float = ...,
        start: Optional[_Start] = ...,
        samples: Optional[int] = ...,
        horizon: Optional[int] = ...,
        temperature: Optional[float] = ...,
        history: float = ...,
    ) -> None: ...
    def tick(
        self,
        t: float,
        inputs: Sequence[float],
        pose: Optional[Sequence[float]] = ...,
        imu_yaw_rate: Optional[float] = ...,
    ) -> dict[str, Any]: ...
    def reset(self) -> None: ...
    @property
    def length(self) -> float: ...

def load_dataset(path: Optional[_Path] = ..., sidecar: Optional[_Path] = ...) -> Dataset: ...
def load_model(path: _Path) -> Model: ...
def fit(dataset: Dataset, model: str, split: Optional[float] = ..., start: Optional[_Start] = ..., allow_useless: bool = ...) -> Model: ...
def evaluate(dataset: Dataset, models: _Models = ..., split: float = ..., start: Optional[_Start] = ..., progress: Any = ..., allow_useless: bool = ...) -> dict[str, Any]: ...
def per_window(dataset: Dataset, models: _Models = ..., split: float = ..., start: Optional[_Start] = ..., allow_useless: bool = ...) -> dict[str, Any]: ...
def bench(suite: Optional[_Path] = ..., models: _Models = ..., split: float = ..., transfer: bool = ..., allow_useless: bool = ..., progress: Any = ..., adapt: Union[bool, Sequence[float]] = ..., adapt_library: bool = ...) -> dict[str, Any]: ...
def adapt(prior: Union[Model, Dataset], data: Dataset, models: _Models = ..., split: float = ..., times: Optional[Sequence[float]] = ..., progress: Any = ..., allow_useless: bool = ...) -> dict[str, Any]: ...
def track(progress: Any = ..., **options: Any) -> dict[str, Any]: ...
def sim_fit(dataset: Union[Dataset, _Path], robot: _Path, progress: Any = ..., **options: Any) -> dict[str, Any]: ...
def import_raw(
    path: _Path,
    robot: _Path,
    *,
    max_gap: float = ...,
    localization_timeout: float = ...,
    terrain: str = ...,
    allow: Union[str, Sequence[str]] = ...,
) -> Dataset: ...
def import_bag(
    path: _Path,
    robot: _Path,
    topics: Union[None, Mapping[str, str], Sequence[str]] = ...,
    *,
    max_gap: float = ...,
    localization_timeout: float = ...,
    terrain: str = ...,
    allow: Union[str, Sequence[str]] = ...,
) -> Dataset: ...
def report(
    dataset: Dataset,
    out: _Path,
    models: _Models = ...,
    split: float = ...,
    model: str = ...,
    robot: Optional[_Path] = ...,
    progress: Any = ...,
    allow_useless: bool = ...,
) -> str: ...
