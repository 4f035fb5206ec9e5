"""netCDF records: a record that bearingdyn saved (``save_dataset`` of a record, ``kind =
"record"``) is read back with its provenance; any other netCDF file whose variables lie
over one uniform time coordinate ``t`` or ``time`` (s) is read as channels. A simulated
run stays a run: it is refused here (``bearingdyn spectrum`` and the others read it as
one)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from analysis.errors import InputError
from analysis.measured.readers import Channel, Raw, as_column, identifier

SPEED = "speed_rpm"


def read(path: Path) -> Raw:
    """The channels of a netCDF record (see the module)."""
    from analysis.io import open_result

    data = open_result(path)
    if data.attrs.get("kind") != "record" and isinstance(data.attrs.get("model"), str):
        raise InputError(f"record: '{path}' is a simulated result of "
                         f"{data.attrs['model']}, not a measured record; give it to the "
                         "commands as a run")
    time = next((name for name in ("t", "time") if name in data.coords), None)
    if time is None:
        raise InputError(f"record: '{path}' has no time coordinate t (s); variables: "
                         f"{', '.join(map(str, data.data_vars)) or 'none'}")
    channels = []
    for name, var in data.data_vars.items():
        if var.dims != (time,) or name == SPEED:
            continue
        units = var.attrs.get("units")
        channels.append(Channel(identifier(str(name)), as_column(var.values, str(name), path),
                                None if units in (None, "") else str(units),
                                str(var.attrs.get("long_name", name)),
                                str(var.attrs.get("original_name", name))))
    if not channels:
        raise InputError(f"record: '{path}' has no variable over {time}")
    raw = Raw(channels, "xarray.open_dataset (h5netcdf)",
              t=np.asarray(data[time].values, dtype=float), fs_source="file: time coordinate")
    if data.attrs.get("kind") == "record":
        raw.attrs = dict(data.attrs)
        if SPEED in data.data_vars:
            raw.speed_curve = np.asarray(data[SPEED].values, dtype=float)
    return raw
