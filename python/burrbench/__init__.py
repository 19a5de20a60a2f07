"""burrbench from Python: read its files, run the model, replay and calibrate.

    import burrbench
    pred = burrbench.replay("experiment.toml", "params.toml")
    fit = burrbench.read_fit("cal/fit.json")

Every reader checks the file with burrbench's own C++ reader first (the same checks and
the same one-line InputError as the command line), then returns plain Python: dicts,
numpy arrays, str. docs/python.md lists the API with units."""
from ._burrbench import InputError, Volume, __version__, contact, validate  # noqa: F401
from ._burrbench import calibrate as _calibrate
from ._burrbench import replay as _replay
from .readers import (Group, read_criteria, read_experiment, read_fit, read_metrics,  # noqa: F401
                      read_params, read_prediction, read_recording, read_sample, read_sensor_loads)

import os as _os


def replay(experiment, params, step_us=0.0, erosion=True, threads=2, progress=None):
    """Replays every recording of an experiment (as `burrbench replay`): a Group
    {recording id: Group of numpy arrays}, each array's unit in `.units`, its frame in
    `.frames`. `params` is a params.toml path or a dict {class: {id, alpha_N_per_mm2,
    c1_N_per_mm2, mu}}. `threads` recordings are replayed at once (the result does not
    depend on it). `progress(fraction, line)` receives the progress lines. The GIL is
    released while the model runs. Arguments are taken as given, never converted: a
    wrong type raises InputError naming it."""
    raw = _replay(_os.fspath(experiment), params if isinstance(params, dict) else _os.fspath(params),
                  step_us, erosion, threads, progress)
    from .readers import _prediction_units
    return Group({rid: _prediction_units(Group(rec)) for rid, rec in raw.items()})


def calibrate(experiment, progress=None, **options):
    """Calibrates as `burrbench calibrate` (no files written): {"fit": fit.json's content,
    "params": {class: {...}}, "summary": str}. `progress(fraction, line)` receives the
    progress lines with the whole run's fraction done (in [0, 1], never falling, 1.0 on the
    last line); keyword options as in docs/python.md (threads, starts, profiles,
    cross_validate, discretization_check, derivatives, ...)."""
    return _calibrate(_os.fspath(experiment), progress, **options)
