"""Readers for every burrbench format. Each file is first checked by the C++ reader of
its format (`validate`), then read here into plain Python: HDF5 groups become Group
dicts of numpy arrays (strings decoded to str), TOML and JSON become dicts."""
import json
import os
import tomllib

from ._burrbench import prediction_units, validate


class Group(dict):
    """A dict of a file's group: datasets as numpy arrays, subgroups as Groups.
    `.attrs`: the group's attributes (str, numbers, arrays); `.units`: name → unit of
    each dataset that states one; `.frames`: name → frame ("volume", "sensor", "rig")
    from the burrbench naming convention (…_vol…, …_sensor…, …_rig…)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.attrs = {}
        self.units = {}
        self.frames = {}

    def to_pandas(self):
        """The group's equal-length 1-D and n×3 arrays as a pandas DataFrame (n×3 arrays
        become name_x, name_y, name_z columns). Needs python3-pandas."""
        import pandas as pd
        import numpy as np
        cols, n = {}, None
        for k, v in self.items():
            if not isinstance(v, np.ndarray) or v.ndim == 0:
                continue
            if n is None:
                n = len(v)
            if len(v) != n:
                continue
            if v.ndim == 1:
                cols[k] = v
            elif v.ndim == 2 and v.shape[1] == 3:
                for i, a in enumerate("xyz"):
                    cols[f"{k}_{a}"] = v[:, i]
        return pd.DataFrame(cols)


def _frame(name):
    for key, frame in (("_vol", "volume"), ("_sensor", "sensor"), ("_rig", "rig")):
        if key in name:
            return frame
    return None


def _decode(v):
    import numpy as np
    if isinstance(v, bytes):
        return v.decode("utf-8")
    if isinstance(v, np.ndarray) and v.dtype.kind in "SO":
        return [x.decode("utf-8") if isinstance(x, bytes) else x for x in v.tolist()]
    return v


def _h5group(g):
    import h5py
    out = Group()
    out.attrs = {k: _decode(v) for k, v in g.attrs.items()}
    for name, item in g.items():
        if isinstance(item, h5py.Group):
            out[name] = _h5group(item)
        else:
            value = item[()]
            if item.dtype.kind in "SO":
                value = _decode(value)
            out[name] = value
            if "unit" in item.attrs:
                out.units[name] = _decode(item.attrs["unit"])
            frame = _frame(name)
            if frame:
                out.frames[name] = frame
    return out


def _read_h5(kind, path):
    import h5py
    path = os.fspath(path)
    validate(kind, path)
    with h5py.File(path, "r") as f:
        return _h5group(f)


def read_recording(path):
    """A recording (burrbench.recording): streams/<device>/channels/<name> arrays with
    their units, events, meta, provenance."""
    return _read_h5("recording", path)


def read_sample(path):
    """A sample volume (burrbench.sample): labels and bone fraction, attrs voxel_size_mm
    and origin_mm (centre of voxel (0,0,0), volume frame)."""
    return _read_h5("sample", path)


def _prediction_units(rec):
    """Units of an in-memory prediction (replay), from the format's own table: the same
    strings the file's @unit attributes carry."""
    rec.units.update({k: u for k, u in prediction_units().items() if k in rec})
    rec.frames.update({k: _frame(k) for k in rec if _frame(k)})
    return rec


def read_prediction(path):
    """A prediction (burrbench.prediction): recordings/<id>/<series> arrays with units."""
    return _read_h5("prediction", path)


def _read_toml(kind, path):
    path = os.fspath(path)
    validate(kind, path)
    with open(path, "rb") as f:
        return tomllib.load(f)


def read_params(path):
    """A parameter set (burrbench.params): {"classes": {name: {id, alpha_N_per_mm2,
    c1_N_per_mm2, mu}}, ...}; α and C1 in N/mm², μ dimensionless."""
    return _read_toml("params", path)


def read_experiment(path):
    """An experiment manifest (burrbench.experiment) as a dict."""
    return _read_toml("experiment", path)


def read_criteria(path):
    """Acceptance criteria (burrbench.criteria) as a dict."""
    return _read_toml("criteria", path)


def read_sensor_loads(path):
    """Static loads for `rig sensor-pose` (burrbench.sensor_loads) as a dict."""
    return _read_toml("sensor_loads", path)


def _read_json(kind, path):
    path = os.fspath(path)
    validate(kind, path)
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def read_fit(path):
    """A fit result (burrbench.fit): parameters, nuisances, covariance, ... (NaN as None)."""
    return _read_json("fit", path)


def read_metrics(path):
    """Validation metrics (burrbench.metrics): rows, criteria results, provenance."""
    return _read_json("metrics", path)
