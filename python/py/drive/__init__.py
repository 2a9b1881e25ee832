"""DRIVE from Python: datasets, the paper's evaluation, fitted models with numpy predictions.

    >>> import drive
    >>> data = drive.load_dataset()                 # the bundled Husky data
    >>> result = drive.evaluate(data)               # the dict of `drive eval --json`
    >>> model = drive.fit(data, "slip-blr", split=0.5)
    >>> poses = model.predict(commands)             # (H, 2) -> (H, 3): x, y, yaw

Every user error raises `drive.DriveError` (a ValueError) with the command line's message.
"""

import json as _json

from ._native import Dataset, DriveError, Model, fit, load_dataset, load_model
from ._native import evaluate_json as _evaluate_json

__all__ = ["Dataset", "DriveError", "Model", "evaluate", "fit", "load_dataset", "load_model"]


def evaluate(dataset, models=None, split=0.5):
    """The models (default: naive, powertrain, slip-blr, acc-blr) fitted on the first
    `split` of the dataset's intervals and scored on the rest: the same dict as
    `drive eval --json`."""
    if isinstance(models, str):
        models = [m.strip() for m in models.split(",") if m.strip()]
    return _json.loads(_evaluate_json(dataset, None if models is None else list(models), float(split)))
