"""Datasets to and from pandas DataFrames: what `Dataset.to_pandas` and
`Dataset.from_pandas` run."""

import json as _json
from collections.abc import Mapping as _Mapping

import numpy as _np

from ._native import Dataset, DriveError, columns_for_sidecar


def dataset_to_pandas(self):
    """The window CSV as a pandas DataFrame (one row per sample, the command line's
    columns and values); `Dataset.from_pandas(df, dataset.meta)` gives the dataset back."""
    import pandas

    return pandas.DataFrame(self._columns())


def dataset_from_pandas(df, meta):
    """A dataset from a DataFrame with the window CSV's columns (what `to_pandas` or
    `pandas.read_csv` of a project CSV gives) and the sidecar as a dict (what `meta` or
    `json.load` of a sidecar gives). Data handed over in memory is taken as it is: the
    sidecar's checksum of its CSV file is not checked; extra columns are left out with a
    warning; an error names the DataFrame's column and row."""
    import re
    import warnings

    if not hasattr(df, "columns") or not hasattr(df, "to_csv"):
        raise DriveError(f"df must be a pandas DataFrame with the window CSV's columns, got {type(df).__name__}")
    if not isinstance(meta, _Mapping):
        raise DriveError(f"meta must be a dict (the sidecar JSON's fields), got {type(meta).__name__}")
    meta = {k: v for k, v in meta.items() if k != "csv"}
    for key, value in meta.items():
        if isinstance(value, float) and not _np.isfinite(value):
            raise DriveError(f"meta, field {key!r}: {value!r} is not a finite number")

    def plain(o):
        # numpy scalars (meta["windows"] = df["window"].max() + 1) as Python numbers.
        if isinstance(o, _np.generic):
            return o.item()
        raise TypeError(f"{type(o).__name__} is not a JSON value")

    try:
        sidecar = _json.dumps(meta, default=plain, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise DriveError(f"meta cannot be a sidecar: {e}") from None
    required = columns_for_sidecar(sidecar)
    columns = [str(c) for c in df.columns]
    duplicated = sorted({c for c in columns if columns.count(c) > 1})
    if duplicated:
        raise DriveError(f"df has the column {duplicated[0]!r} more than once")
    missing = [c for c in required if c not in columns]
    if missing:
        raise DriveError(f"df: missing column {missing[0]!r} (required: {', '.join(required)})")
    extra = [c for c in columns if c not in required and c != "calib_step"]
    if extra:
        warnings.warn(f"Dataset.from_pandas: columns left out: {', '.join(extra)}", stacklevel=2)
    frame = df[required]
    import pandas

    for name in required:
        if name == "phase":
            phases = frame[name].astype(str)
            bad = ~phases.isin(["transient", "steady"]).to_numpy()
            if bad.any():
                position = int(_np.argmax(bad))
                raise DriveError(
                    f"DataFrame column 'phase', row {position} (index {frame.index[position]!r}): "
                    f"{frame[name].iloc[position]!r} is neither 'transient' nor 'steady'"
                )
            continue
        values = frame[name]
        if values.dtype == bool:
            bad = _np.ones(len(values), dtype=bool)
        else:
            numbers = pandas.to_numeric(values, errors="coerce").to_numpy(dtype=float, na_value=_np.nan)
            bools = values.map(lambda v: isinstance(v, (bool, _np.bool_))).to_numpy(dtype=bool)
            bad = ~_np.isfinite(numbers) | bools
        if bad.any():
            position = int(_np.argmax(bad))
            raise DriveError(
                f"DataFrame column {name!r}, row {position} (index {frame.index[position]!r}): "
                f"{values.iloc[position]!r} is not a finite number"
            )
    csv = frame.to_csv(index=False)
    try:
        return Dataset.from_text(csv, sidecar)
    except DriveError as e:
        # The parser counts CSV lines (the header is line 1): say the DataFrame's row.
        def row(m):
            position = int(m.group(1)) - 2
            label = frame.index[position] if 0 <= position < len(frame.index) else None
            return f"DataFrame row {position} (index {label!r})"

        raise DriveError(re.sub(r"DataFrame, line (\d+)", row, str(e))) from None
