"""Write a run's netCDF4 file with netCDF4-python directly: the file xarray writes, without
importing xarray.

``Dataset.to_netcdf`` costs a fresh process about 1 s before the first byte (importing xarray
and pandas; xarray then imports dask, and dask.distributed, to ask whether the arrays are
chunked and which scheduler holds the file lock) and ~0.1 s of per-variable wrapping per file:
more than the integration of a catalogue run. :func:`write` makes the same library calls in the
same order as xarray's netCDF4 backend does for the dataset of ``SimResult.to_xarray`` with the
encoding of ``SimResult.to_netcdf``: global attributes, dimensions in order of first use, then
each variable (created with the same chunking, compression and fill settings, its attributes,
its CF ``coordinates`` attribute naming the auxiliary label coordinates it spans, its values).
The file is byte for byte xarray's (tests/test_first_run.py compares the bytes on catalogue
runs, with and without float32, decimation and compression).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["write"]


def write(
    path: str | Path,
    data: Mapping[str, Any],
    coords: Mapping[str, Any],
    attrs: Mapping[str, Any],
    *,
    float32: bool,
    complevel: int,
) -> None:
    """Write the variables ``data`` and ``coords`` (``name -> (dims, values, attributes)``,
    as ``SimResult._layout`` gives them) and the global ``attrs`` to a new netCDF4 file."""
    import netCDF4

    variables = []
    for name, (dims, values, var_attrs) in (*data.items(), *coords.items()):
        dims = (dims,) if isinstance(dims, str) else tuple(dims)
        variables.append((name, dims, np.asarray(values), dict(var_attrs)))
    # the auxiliary coordinates (labels of a dimension) each variable spans: CF "coordinates"
    labels = {
        name: set(dims) for name, dims, _, _ in variables if name in coords and name not in dims
    }
    unattached = set(labels)
    for name, dims, _, var_attrs in variables:
        if name in labels or "coordinates" in var_attrs:
            continue
        spanned = sorted(
            c for c, c_dims in labels.items() if name not in dims and c_dims <= set(dims)
        )
        if spanned:
            var_attrs["coordinates"] = " ".join(spanned)
            unattached.difference_update(spanned)
    attrs = dict(attrs)
    if unattached:  # labels no variable spans: xarray lists them globally
        attrs["coordinates"] = " ".join(sorted(unattached))
    sizes: dict[str, int] = {}
    for _, dims, values, _ in variables:
        for dim, n in zip(dims, values.shape, strict=True):
            sizes.setdefault(dim, n)
    with netCDF4.Dataset(str(path), mode="w", clobber=True, format="NETCDF4") as nc:
        for key, value in attrs.items():
            if isinstance(value, list) and value and all(isinstance(v, str) for v in value):
                nc.setncattr_string(key, value)
            else:
                nc.setncattr(key, value)
        for dim, n in sizes.items():
            nc.createDimension(dim, size=n)
        for name, dims, values, var_attrs in variables:
            if values.dtype.kind == "U":
                datatype: Any = str
            elif values.dtype.kind in "iufc":
                datatype = values.dtype
            else:  # pragma: no cover - the layout holds numbers and text only
                raise TypeError(f"netCDF variable {name!r}: unsupported dtype {values.dtype}")
            options: dict[str, Any] = {"zlib": False, "fill_value": None}
            if values.dtype.kind == "f":
                if complevel and values.ndim and values.size:
                    options["zlib"] = True
                    options["complevel"] = complevel
                if float32 and name != "time":
                    values = values.astype(np.float32)
                    datatype = values.dtype
            var = nc.createVariable(
                name,
                datatype,
                dims,
                complevel=options.pop("complevel", 4),
                shuffle=True,
                fletcher32=False,
                contiguous=False,
                chunksizes=None,
                endian="native",
                least_significant_digit=None,
                **options,
            )
            var.setncatts(var_attrs)
            var.set_auto_maskandscale(False)
            var[...] = values
