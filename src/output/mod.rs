//! Output writers: HDF5, summary.json, CSV (in progress).
