"""The run's context that calibrate and validate store in prediction.h5 (/context, JSON as
UTF-8 bytes; docs/formats.md): what the report states beside the series — findings,
constants, recordings' files and logs, the verification study."""
import json
from pathlib import Path

import h5py


def context(folder):
    with h5py.File(Path(folder) / "prediction.h5", "r") as f:
        return json.loads(bytes(f["context"][()]).decode("utf-8"))
