"""WAV records (``scipy.io.wavfile``): the rate is the file's; each channel of the file is a
channel ``ch1``, ``ch2``, …

The scale, stated: integer PCM is divided by its full scale (2^15 for 16-bit, 2^31 for
32-bit, 2^7 around 128 for 8-bit unsigned), so its values lie in [-1, 1); a float WAV is
taken as it is. ``read_record`` then multiplies by ``--scale`` (units per full scale,
default 1) and gives the channels ``--units`` (default ``1``: the file does not say)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from analysis.measured.readers import Channel, Raw, unreadable

FULL_SCALE = {"int16": 2.0**15, "int32": 2.0**31, "uint8": 2.0**7, "int64": 2.0**63}
"""Integer PCM: the value of full scale (1.0) per sample type; uint8 is offset by 128."""


def read(path: Path) -> Raw:
    """The channels of a WAV file in [-1, 1) times ``--scale`` (see the module)."""
    import warnings

    import scipy.io.wavfile

    try:
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always", scipy.io.wavfile.WavFileWarning)
            rate, data = scipy.io.wavfile.read(path, mmap=False)
    except (ValueError, OSError, EOFError) as exc:
        raise unreadable(path, "WAV", exc) from None
    cut = [w for w in said if "prematurely" in str(w.message)]
    if cut:  # scipy returns what a truncated file holds: refused, not half a record
        raise unreadable(path, "WAV", ValueError(f"truncated: {cut[0].message}"))
    kind = str(data.dtype)
    values = data.astype(np.float64)
    if kind == "uint8":
        values -= 128.0
    if kind in FULL_SCALE:
        values /= FULL_SCALE[kind]
        how = f"{kind} PCM / {FULL_SCALE[kind]:.0f}"
    else:
        how = f"{kind} as stored"
    values = values.reshape(values.shape[0], -1)
    channels = [Channel(f"ch{i + 1}", values[:, i], None, f"WAV channel {i + 1} ({how})")
                for i in range(values.shape[1])]
    return Raw(channels, "scipy.io.wavfile.read", fs=float(rate), fs_source="file",
               attrs={"wav_scale": f"{how}, then x --scale (default 1) in --units"})
